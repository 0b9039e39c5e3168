//! The progress bar of a run on standard error (only if it is a terminal).

use std::io::IsTerminal;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use lasalle::{simulate_with_progress, Recording, RunError, RunModel, RunSpec, State};

/// A progress bar over [0, 1000], drawn on standard error only if `enabled` and it is a
/// terminal.
pub fn progress_bar(enabled: bool, label: &str) -> ProgressBar {
    if !enabled || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(Some(1000), ProgressDrawTarget::stderr());
    if let Ok(style) = ProgressStyle::with_template(
        "{msg:>28} [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta}",
    ) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(label.to_string());
    bar
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
    let bar = progress_bar(shown, &spec.method.to_string());
    let t_end = spec.t_end;
    let recording = simulate_with_progress(model, x0, spec, &|t| {
        bar.set_position((t / t_end * 1000.0) as u64)
    });
    bar.finish_and_clear();
    recording
}
