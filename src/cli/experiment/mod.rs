//! `lasalle experiment <name>`: the paper's §4 experiments (rigid-body, kepler,
//! perturbed-kepler; Chang, Jiménez & Perlmutter 2016, Figs. 1–10), the gain study (gains), the
//! gains of adaptive methods (adaptive-gains), the thesis' SO(3) systems (so3), and from NASA
//! TM X-53478 the primer vector on coast arcs (primer-vector), Infante's Table I (infante) and
//! the multipliers across coordinate systems (multipliers).
//!
//! Each experiment runs its methods through the same core as `lasalle run`
//! ([`lasalle::simulate`]) and writes into `--out` (default `out/experiment-<name>/`):
//! one `<method>.csv` per method (t, state, invariant errors), `summary.md` (the tables, with
//! the command that regenerates them), `summary.json`, and the figures `figN_*.svg` / `.png`.
//! `--t-end` / `--periods` shorten the runs (the tests use that).

mod adaptive_gains;
mod gains;
mod hypotheses;
mod infante;
mod kepler;
mod multipliers;
mod perturbed_kepler;
mod primer;
mod rigid_body;
mod so3;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use clap::Args;

use super::plot::{thin, write_figure, Chart, Style};
use lasalle::{Method, Recording, RunError};

use super::args::normalise;
use super::CliResult;

/// Arguments of `lasalle experiment`.
#[derive(Args, Debug, Clone)]
pub struct ExperimentArgs {
    /// rigid-body (Figs. 1–4), kepler (Figs. 5–7), perturbed-kepler (Figs. 8–10), gains (the
    /// gain study), adaptive-gains (gains for DOPRI5 and Taylor; not part of `all`), so3 (the
    /// thesis' four extremal systems with reconstruction), primer-vector (the primer vector on
    /// Kepler coast arcs, closed form against integration; not part of `all`), infante
    /// (Infante's Table I, solved symbolically; not part of `all`), multipliers (the Lagrange
    /// multipliers carried from the plumb-line to the flight-path frame along a thrusting
    /// extremal; not part of `all`), or all.
    pub name: String,
    /// Output directory (default: out/experiment-<name>/).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// End time instead of the paper's (rigid body 1000, perturbed Kepler 200).
    #[arg(long, value_parser = super::value::positive, allow_hyphen_values = true)]
    pub t_end: Option<f64>,
    /// Kepler: number of periods T = 70.2481 instead of the paper's 1000.
    #[arg(long, value_parser = super::value::positive, allow_hyphen_values = true)]
    pub periods: Option<f64>,
    /// Step size instead of the paper's Δt.
    #[arg(long, value_parser = super::value::positive, allow_hyphen_values = true)]
    pub dt: Option<f64>,
    /// Skip the figures.
    #[arg(long)]
    pub no_figures: bool,
    /// No progress bars and no tables on standard output.
    #[arg(long, short)]
    pub quiet: bool,
}

/// The paper's experiments, one per system of its §4.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Paper {
    RigidBody,
    Kepler,
    PerturbedKepler,
}

impl Paper {
    const ALL: [Paper; 3] = [Paper::RigidBody, Paper::Kepler, Paper::PerturbedKepler];

    fn name(self) -> &'static str {
        match self {
            Paper::RigidBody => "rigid-body",
            Paper::Kepler => "kepler",
            Paper::PerturbedKepler => "perturbed-kepler",
        }
    }
}

/// Which experiment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Which {
    Paper(Paper),
    Gains,
    AdaptiveGains,
    So3,
    Primer,
    Infante,
    Multipliers,
    All,
}

/// Runs `lasalle experiment`.
pub fn run(args: &ExperimentArgs) -> CliResult {
    let which = match args.name.as_str() {
        "gains" | "gain" => Which::Gains,
        "adaptive-gains" => Which::AdaptiveGains,
        "so3" => Which::So3,
        "primer-vector" | "primer" => Which::Primer,
        "infante" => Which::Infante,
        "multipliers" => Which::Multipliers,
        "all" => Which::All,
        other => Which::Paper(
            Paper::ALL
                .into_iter()
                .find(|p| normalise(p.name()) == normalise(other))
                .ok_or_else(|| {
                    super::usage(format!(
                        "unknown experiment `{other}`; experiments: rigid-body, kepler, perturbed-kepler, gains, adaptive-gains, so3, primer-vector, infante, multipliers, all (use `lasalle run {other}` to integrate a model)"
                    ))
                })?,
        ),
    };
    match which {
        Which::Paper(p) => run_one(args, p),
        Which::Gains => gains::run(args, &out_dir(args, "gains")?),
        Which::AdaptiveGains => adaptive_gains::run(args, &out_dir(args, "adaptive-gains")?),
        Which::So3 => so3::run(args, &out_dir(args, "so3")?),
        Which::Primer => primer::run(args, &out_dir(args, "primer-vector")?),
        Which::Infante => infante::run(args, &out_dir(args, "infante")?),
        Which::Multipliers => multipliers::run(args, &out_dir(args, "multipliers")?),
        Which::All => {
            for p in Paper::ALL {
                run_one(args, p)?;
            }
            gains::run(args, &out_dir(args, "gains")?)?;
            so3::run(args, &out_dir(args, "so3")?)
        }
    }
}

fn run_one(args: &ExperimentArgs, experiment: Paper) -> CliResult {
    let dir = out_dir(args, experiment.name())?;
    match experiment {
        Paper::RigidBody => rigid_body::run(args, &dir),
        Paper::Kepler => kepler::run(args, &dir),
        Paper::PerturbedKepler => perturbed_kepler::run(args, &dir),
    }
}

/// `--out` (with `all`: a subdirectory per experiment) or `out/experiment-<name>`; created.
fn out_dir(args: &ExperimentArgs, name: &str) -> Result<PathBuf, String> {
    let dir = match (&args.out, args.name.as_str()) {
        (Some(d), "all") => d.join(format!("experiment-{name}")),
        (Some(d), _) => d.clone(),
        (None, _) => PathBuf::from(format!("out/experiment-{name}")),
    };
    std::fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    Ok(dir)
}

/// The command line that reproduces this run (for the reports).
fn command_line(args: &ExperimentArgs, name: &str) -> String {
    let mut c = format!("cargo run --release -- experiment {name}");
    if let Some(t) = args.t_end {
        let _ = write!(c, " --t-end {t}");
    }
    if let Some(p) = args.periods {
        let _ = write!(c, " --periods {p}");
    }
    if let Some(dt) = args.dt {
        let _ = write!(c, " --dt {dt}");
    }
    c
}

/// Scientific notation with 3 significant digits; NaN/∞ spelled out.
pub(crate) fn sci(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.3e}")
    } else {
        format!("{v}")
    }
}

/// A markdown table.
#[derive(Default)]
struct Table {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Table {
    fn new(header: &[&str]) -> Self {
        Table {
            header: header.iter().map(|s| s.to_string()).collect(),
            rows: Vec::new(),
        }
    }

    fn row(&mut self, cells: Vec<String>) {
        self.rows.push(cells);
    }

    fn markdown(&self) -> String {
        let mut s = String::new();
        // a `|` inside a cell (|ΔE|) must be escaped in markdown
        let line = |cells: &[String]| {
            let escaped: Vec<String> = cells.iter().map(|c| c.replace('|', "\\|")).collect();
            format!("| {} |", escaped.join(" | "))
        };
        let _ = writeln!(s, "{}", line(&self.header));
        let _ = writeln!(s, "|{}", " --- |".repeat(self.header.len()));
        for r in &self.rows {
            let _ = writeln!(s, "{}", line(r));
        }
        s
    }
}

/// The note on a run that stopped early, or the empty string.
fn failure_note(trace: &Recording) -> String {
    match &trace.failure {
        Some(e) => format!(
            "stopped at t = {:.4}: {}",
            e.time().unwrap_or(f64::NAN),
            e.to_string().split(';').next().unwrap_or("")
        ),
        None => String::new(),
    }
}

/// Writes each trace as `<method>.csv`, `summary.md` and `summary.json`; prints the report
/// unless quiet.
fn write_outputs(
    dir: &Path,
    traces: &[&Recording],
    report: &str,
    json: serde_json::Value,
    quiet: bool,
) -> CliResult {
    for t in traces {
        t.write_csv(dir.join(format!("{}.csv", t.method)))?;
    }
    std::fs::write(dir.join("summary.md"), report)?;
    std::fs::write(
        dir.join("summary.json"),
        serde_json::to_string_pretty(&json)? + "\n",
    )?;
    if !quiet {
        println!("{report}");
        println!("wrote {}", dir.display());
    }
    Ok(())
}

/// Runs a method and fails on invalid arguments (a blow-up is kept in the trace).
fn must(r: Result<Recording, RunError>) -> Result<Recording, Box<dyn std::error::Error>> {
    r.map_err(Into::into)
}

/// One figure of an invariant's error |f(t) − f(0)| over t for every method, on a log scale:
/// the paper's Figs. 2–4, 6–7 and 9–10.
fn error_figure(
    dir: &Path,
    (stem, block, title, label): (&str, &str, &str, &str),
    traces: &[Recording],
    methods: &[(Method, usize, &str)],
) -> CliResult {
    let mut c = Chart::new(title, "t", label, true);
    for (t, &(_, color, name)) in traces.iter().zip(methods) {
        let b = t.block(block).unwrap_or(0);
        let (x, y) = thin(&t.t, &t.error_series(b), 4000);
        c.add(name, x, y, color, Style::Line);
    }
    write_figure(dir, stem, &[c], (1, 1), (900, 560))
}
