//! The variational flags of `lasalle run` (`--variational`, `--lyapunov-spectrum`, `--megno`,
//! `--fli`) and the stability maps of `lasalle sweep --indicator megno|mle|fli`: the library's
//! [`lasalle::run::chaos`] runs, their numbers in `summary.json`, Φ(t_end) as `stm.csv`, and
//! the map's figure.

use std::path::Path;
use std::time::Instant;

use clap::{Args, ValueEnum};
use lasalle::run::chaos;
use lasalle::{LoadedModel, ModelInfo, RunSpec};
use serde_json::{json, Value};

use super::plot::write_heat_map;
use super::progress::RunProgress;
use super::{usage, value, CliResult, Given};

/// The variational flags of `lasalle run`.
#[derive(Args, Debug, Default)]
pub struct ChaosArgs {
    /// Also integrate the variational equations Φ̇ = DX·Φ, Φ(0) = I (derived symbolically):
    /// Φ(t_end) goes into summary.json (`variational`) and stm.csv.
    #[arg(long)]
    pub variational: bool,
    /// Also compute the Lyapunov spectrum (Benettin et al. 1980: N tangent vectors,
    /// re-orthonormalised by QR every --renormalise-every time units) into summary.json
    /// (`lyapunov_spectrum`).
    #[arg(long)]
    pub lyapunov_spectrum: bool,
    /// The time between two QR re-orthonormalisations of --lyapunov-spectrum.
    #[arg(long, default_value_t = 1.0, value_parser = value::positive, allow_hyphen_values = true)]
    pub renormalise_every: f64,
    /// Also compute MEGNO (Cincotta & Simó 2000): ⟨Y⟩ at t_end into summary.json (`megno`;
    /// → 0 on isochronous periodic orbits, → 2 on quasi-periodic ones, grows like λt/2 on
    /// chaotic ones), with Y(t_end) (`megno_y`) and the maximal exponent's estimate (`mle`).
    #[arg(long)]
    pub megno: bool,
    /// Also compute the fast Lyapunov indicator, the supremum of ln‖w(t)‖ over [0, t_end] for
    /// a tangent vector w of unit length at t = 0 (Froeschlé, Lega & Gonczi 1997), into
    /// summary.json (`fli`).
    #[arg(long)]
    pub fli: bool,
}

impl ChaosArgs {
    /// Was any variational flag given?
    pub fn any(&self) -> bool {
        self.variational || self.lyapunov_spectrum || self.megno || self.fli
    }
}

/// The variational runs `args` asks for, from the run's own model, start and spec; their
/// results go into `summary` (and Φ into `dir/stm.csv`), with the time and the steps each run
/// took under `extended_runs`. Each run draws a progress bar if `shown` (on a terminal, once
/// it has taken a few seconds).
pub fn extend_summary(
    args: &ChaosArgs,
    (model, x0, spec): (&LoadedModel, &[f64], &RunSpec),
    dir: &Path,
    summary: &mut Value,
    given: &Given,
    shown: bool,
) -> CliResult {
    if !args.lyapunov_spectrum {
        given.refuse(&["renormalise_every"], "applies to --lyapunov-spectrum")?;
    }
    if !args.any() {
        return Ok(());
    }
    chaos::check_method(spec.method).map_err(usage)?;
    let mut spec = spec.clone();
    spec.every = u64::MAX;
    let mut runs = serde_json::Map::new();
    // times the run `name` (from its start: deriving and compiling the extension included)
    let mut timed = |name: &str, start: Instant, steps: u64| {
        runs.insert(
            name.into(),
            json!({ "seconds": start.elapsed().as_secs_f64(), "steps": steps }),
        );
    };
    let bar = |label: &str| RunProgress::new(shown, label, spec.t_end);
    if args.variational {
        let (start, bar) = (Instant::now(), bar("variational"));
        let tr = chaos::state_transition_with_progress(model, x0, &spec, &|t| bar.set(t));
        bar.finish();
        let tr = tr.map_err(usage)?;
        failed(&tr.recording, "--variational")?;
        write_stm(dir, model, &tr.phi)?;
        timed("variational", start, tr.recording.steps);
        summary["variational"] = json!({
            "t": tr.recording.t_final(),
            "x": tr.x,
            "phi": tr.phi,
            "steps": tr.recording.steps,
            "file": "stm.csv",
        });
    }
    if args.lyapunov_spectrum {
        let (start, bar) = (Instant::now(), bar("lyapunov spectrum"));
        let interval = args.renormalise_every;
        let sp =
            chaos::lyapunov_spectrum_with_progress(model, x0, &spec, interval, &|t| bar.set(t));
        bar.finish();
        let sp = sp.map_err(usage)?;
        timed("lyapunov_spectrum", start, sp.steps);
        summary["lyapunov_spectrum"] = sp.exponents.clone().into();
        summary["lyapunov_spectrum_qr_order"] = sp.qr_order.clone().into();
        summary["lyapunov_spectrum_sum"] = sp.exponents.iter().sum::<f64>().into();
        summary["renormalise_every"] = args.renormalise_every.into();
        summary["renormalisations"] = sp.renormalisations.into();
    }
    if args.megno || args.fli {
        let (start, bar) = (Instant::now(), bar("indicators"));
        let found = chaos::indicators_with_progress(model, x0, &spec, &|t| bar.set(t));
        bar.finish();
        let (rec, ind) = found.map_err(usage)?;
        failed(&rec, if args.megno { "--megno" } else { "--fli" })?;
        timed("indicators", start, rec.steps);
        if args.megno {
            summary["megno"] = lasalle::json_number(ind.megno_mean);
            summary["megno_y"] = lasalle::json_number(ind.megno);
        }
        if args.fli {
            summary["fli"] = lasalle::json_number(ind.fli);
        }
        summary["mle"] = lasalle::json_number(ind.mle);
    }
    let total: f64 = runs.values().filter_map(|r| r["seconds"].as_f64()).sum();
    summary["extended_runs"] = runs.into();
    summary["extended_seconds"] = total.into();
    Ok(())
}

/// Φ(t_end) as `dir/stm.csv`: a header of the state's components, a row ∂xᵢ(T)/∂x₀ each.
fn write_stm(dir: &Path, model: &LoadedModel, phi: &[Vec<f64>]) -> CliResult {
    let names = lasalle::component_names(model.state_slots());
    let mut csv = String::from("d/dx0");
    for n in &names {
        csv.push_str(&format!(",{n}"));
    }
    csv.push('\n');
    for (n, row) in names.iter().zip(phi) {
        csv.push_str(&format!("{n}(T)"));
        for v in row {
            csv.push_str(&format!(",{v:e}"));
        }
        csv.push('\n');
    }
    std::fs::write(dir.join("stm.csv"), csv)?;
    Ok(())
}

fn failed(rec: &lasalle::Recording, flag: &str) -> CliResult {
    match &rec.failure {
        Some(e) => Err(format!("the run of {flag} stopped: {e}").into()),
        None => Ok(()),
    }
}

/// The indicator of `lasalle sweep --indicator`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Indicator {
    /// MEGNO ⟨Y⟩ (Cincotta & Simó 2000).
    Megno,
    /// The maximal Lyapunov exponent's finite-time estimate ln‖w(t)‖/t.
    Mle,
    /// The fast Lyapunov indicator sup over [0, t] of ln‖w‖ (Froeschlé, Lega & Gonczi 1997).
    Fli,
}

impl Indicator {
    /// Its column in the sweep's table.
    pub fn column(self) -> &'static str {
        match self {
            Indicator::Megno => "megno",
            Indicator::Mle => "mle",
            Indicator::Fli => "fli",
        }
    }

    /// Its value from a run's indicators.
    pub fn of(self, ind: &chaos::Indicators) -> f64 {
        match self {
            Indicator::Megno => ind.megno_mean,
            Indicator::Mle => ind.mle,
            Indicator::Fli => ind.fli,
        }
    }
}

/// Draws the map of `indicator` over the first two columns of the rows (x, y, value; NaN for
/// a failed run) into `<stem>.png` and `<stem>.svg` next to `table`.
pub fn write_map(
    table: &Path,
    indicator: Indicator,
    axes: (&str, &str),
    cells: &[(f64, f64, f64)],
    title: &str,
) -> CliResult {
    let dir = table
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let stem = table
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "map".into());
    let (lo, hi) = match indicator {
        // the scale of Cincotta & Simó's maps: 2 (quasi-periodic) to 8 and beyond (chaotic)
        Indicator::Megno => (0.0, 8.0),
        _ => {
            let mut v: Vec<f64> = cells
                .iter()
                .map(|c| c.2)
                .filter(|v| v.is_finite())
                .collect();
            v.sort_by(f64::total_cmp);
            if v.is_empty() {
                (0.0, 1.0)
            } else {
                (v[v.len() / 100], v[(v.len() * 99) / 100])
            }
        }
    };
    write_heat_map(dir, &stem, title, axes, indicator.column(), cells, (lo, hi))
}

/// The report lines of the variational results in `summary` (for `--format table`), each
/// with the time its run took.
pub fn report(summary: &Value) {
    let took = |run: &str| {
        let r = &summary["extended_runs"][run];
        format!(
            "{:.3} s, {} steps",
            r["seconds"].as_f64().unwrap_or(f64::NAN),
            r["steps"]
        )
    };
    if summary.get("variational").is_some() {
        println!(
            "  Φ(t_end) = ∂x(t_end)/∂x0 in stm.csv ({})",
            took("variational")
        );
    }
    if let Some(l) = summary.get("lyapunov_spectrum") {
        println!(
            "  Lyapunov spectrum, largest first: {l} (sum {}; {})",
            summary["lyapunov_spectrum_sum"],
            took("lyapunov_spectrum")
        );
        if summary.get("lyapunov_spectrum_qr_order") != Some(l) {
            println!(
                "    not converged: the Gram–Schmidt order {} is not yet the decreasing one \
                 (a longer --t-end separates them)",
                summary["lyapunov_spectrum_qr_order"]
            );
        }
    }
    for (key, what) in [
        ("megno", "MEGNO ⟨Y⟩"),
        ("fli", "FLI sup ln‖w‖"),
        ("mle", "ln‖w‖/t"),
    ] {
        if let Some(v) = summary.get(key) {
            println!("  {what} = {v}");
        }
    }
    if summary["extended_runs"].get("indicators").is_some() {
        println!("    ({})", took("indicators"));
    }
}

/// The extension, initial state and extra columns of `lasalle sweep --indicator`.
pub struct SweepIndicator {
    /// The indicator drawn on the map.
    pub indicator: Indicator,
}

impl SweepIndicator {
    /// The model source, extended by the indicators' equations.
    pub fn source(&self, source: lasalle::ModelSource) -> lasalle::ModelSource {
        source.extended(chaos::Extension::Indicators)
    }

    /// The members' start: a point of the model (extended by the front end), or numbers of
    /// the model's own dimension `n`, extended here.
    pub fn init(&self, init: Option<&str>, n: usize) -> Result<lasalle::Init, String> {
        match init {
            None => Ok(lasalle::Init::First),
            Some(text) => match lasalle::parse_numbers(text) {
                Ok(x) if x.len() == n => Ok(lasalle::Init::State(
                    chaos::Extension::Indicators.extend_state(&x),
                )),
                Ok(x) => Err(format!(
                    "--init has {} numbers; the model's state has {n} components",
                    x.len()
                )),
                Err(_) => Ok(lasalle::Init::Text(text.to_string())),
            },
        }
    }

    /// The columns added before `failure`.
    pub fn header() -> [&'static str; 3] {
        ["megno", "mle", "fli"]
    }

    /// Whether the runs must record their events: the FLI's supremum needs the peaks of ℓ
    /// (watching them costs interpolations at every step, which the other maps skip).
    pub fn needs_events(&self) -> bool {
        self.indicator == Indicator::Fli
    }

    /// Their cells for a run of a model of dimension `n` (empty for a failed run; `fli` empty
    /// unless the map is the FLI's, whose runs locate the peaks of ℓ).
    pub fn cells(&self, rec: &lasalle::Recording, n: usize) -> Vec<String> {
        match (&rec.failure, chaos::read_indicators(rec, n)) {
            (None, Some(ind)) => vec![
                ind.megno_mean.to_string(),
                ind.mle.to_string(),
                if self.needs_events() {
                    ind.fli.to_string()
                } else {
                    String::new()
                },
            ],
            _ => vec![String::new(); 3],
        }
    }

    /// The indicator's value of a run (NaN for a failed run).
    pub fn value(&self, rec: &lasalle::Recording, n: usize) -> f64 {
        match (&rec.failure, chaos::read_indicators(rec, n)) {
            (None, Some(ind)) => self.indicator.of(&ind),
            _ => f64::NAN,
        }
    }
}

/// The map of a sweep: the indicator over the rows' first two columns (the first column
/// alone against 0 when the rows have one).
pub fn write_sweep_map(
    table: &Path,
    indicator: Indicator,
    first: &[(String, f64)],
    map: &[(&Vec<(String, f64)>, f64)],
    t_end: f64,
) -> CliResult {
    let x_name = first.first().map_or("row", |c| c.0.as_str());
    let y_name = first.get(1).map_or("", |c| c.0.as_str());
    let cells: Vec<(f64, f64, f64)> = map
        .iter()
        .map(|(row, v)| {
            (
                row.first().map_or(0.0, |c| c.1),
                row.get(1).map_or(0.0, |c| c.1),
                *v,
            )
        })
        .collect();
    let title = format!(
        "{} at t = {t_end}, {} runs",
        indicator.column(),
        cells.len()
    );
    write_map(table, indicator, (x_name, y_name), &cells, &title)
}
