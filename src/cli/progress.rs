//! The progress bar of a run on standard error: only if it is a terminal, and only once the
//! run has taken longer than [`SHOW_AFTER`] (a short run draws nothing).

use std::io::IsTerminal;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use lasalle::{simulate_with_progress, Recording, RunError, RunModel, RunSpec, State};

/// How long a run goes before its progress bar appears.
pub const SHOW_AFTER: Duration = Duration::from_secs(2);

/// A progress bar over a run's time span [0, `t_end`], drawn on standard error once the run
/// has taken [`SHOW_AFTER`], if it was asked for and standard error is a terminal; hidden
/// otherwise.
pub struct RunProgress {
    bar: ProgressBar,
    t_end: f64,
    start: Instant,
    /// Whether to draw once [`SHOW_AFTER`] has passed (asked for, and a terminal).
    drawable: bool,
}

impl RunProgress {
    /// A bar labelled `label` over [0, `t_end`], drawn only if `enabled`.
    pub fn new(enabled: bool, label: &str, t_end: f64) -> RunProgress {
        let bar = ProgressBar::with_draw_target(Some(1000), ProgressDrawTarget::hidden());
        if let Ok(style) = ProgressStyle::with_template(
            "{msg:>28} [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta}",
        ) {
            bar.set_style(style.progress_chars("=> "));
        }
        bar.set_message(label.to_string());
        RunProgress {
            bar,
            t_end,
            start: Instant::now(),
            drawable: enabled && std::io::stderr().is_terminal(),
        }
    }

    /// The run has reached time `t`.
    pub fn set(&self, t: f64) {
        if self.drawable && self.bar.is_hidden() && self.start.elapsed() >= SHOW_AFTER {
            self.bar.set_draw_target(ProgressDrawTarget::stderr());
        }
        let fraction = if self.t_end > 0.0 {
            t / self.t_end
        } else {
            0.0
        };
        self.bar
            .set_position((fraction.clamp(0.0, 1.0) * 1000.0) as u64);
    }

    /// The run is over: the bar goes.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

/// A spinner with a message on standard error, drawn only if it is a terminal.
pub fn spinner() -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
    if let Ok(style) = ProgressStyle::with_template("{spinner} {elapsed_precise} {msg}") {
        bar.set_style(style);
    }
    bar.enable_steady_tick(std::time::Duration::from_millis(200));
    bar
}

/// [`lasalle::simulate`] with a progress bar labelled with the method if `shown`.
pub fn simulate<Mdl, X, FV, K>(
    model: &Mdl,
    x0: &X,
    spec: &RunSpec,
    shown: bool,
) -> Result<Recording, RunError>
where
    Mdl: RunModel<X, FV, K>,
    X: State<f64>,
    FV: State<f64>,
    K: State<f64>,
{
    let bar = RunProgress::new(shown, &spec.method.to_string(), spec.t_end.abs());
    let recording = simulate_with_progress(model, x0, spec, &|t| bar.set(t));
    bar.finish();
    recording
}
