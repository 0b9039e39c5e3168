//! `lasalle stability <model> …`: one command, the analysis chosen by the model's structure
//! (see `docs/stability.md`):
//! - Lie–Poisson (`[--casimir ρ | --at p1,p2,p3] [--range a:b] [--levels n]`): the equilibria on
//!   a Casimir level (or at a given point) with their energy–Casimir / linear verdicts, and the
//!   verdict ranges of every branch of equilibria over a range of Casimir levels;
//! - canonical (`[--time-bound d0,d1 …] [--order N] [--validate]`): the normal-form verdicts
//!   and the time bounds of tubes around the equilibrium;
//! - no Hamiltonian structure (`[--at x1,x2] [--plot FILE]`): domains of attraction of a
//!   dissipative planar field.

use clap::Args;
use lasalle::{LoadedModel, ModelInfo};
use lasalle_analysis::lie_poisson::{self, Equilibrium, Family, Sweep};
use lasalle_analysis::stability::{self, StabilityKind, StabilityOptions};

use super::args::apply_param;
use super::load::{load_with, BackendArg, FamiliesOpt};
use super::{usage, value, CliResult, Given};
use lasalle::parse_numbers;

/// Arguments of `lasalle stability`.
#[derive(Args, Debug)]
pub struct StabilityArgs {
    /// The model: a path to a model file or the name of a built-in model (so3-type-i, …).
    pub model: String,
    /// Set a parameter, `name=value[,value…]`; repeatable.
    #[arg(long, value_name = "NAME=V")]
    pub param: Vec<String>,
    /// The Casimir level |P| = ρ whose equilibria are listed (default: |P| of the model's
    /// first named point, else 1).
    #[arg(long, conflicts_with = "at", value_parser = value::positive, allow_hyphen_values = true)]
    pub casimir: Option<f64>,
    /// Analyse this point instead (it must be an equilibrium): P1,P2,P3 for Lie–Poisson
    /// models, x1,x2 for planar dissipative ones.
    #[arg(long, allow_hyphen_values = true, value_name = "POINT")]
    pub at: Option<String>,
    /// The range of Casimir levels of the family summary, `a:b` (default: up to three times
    /// the largest of 1, |parameters| and the level).
    #[arg(long, value_name = "A:B")]
    pub range: Option<String>,
    /// Number of levels in the family summary.
    #[arg(long, default_value_t = 121, value_parser = value::size, allow_hyphen_values = true)]
    pub levels: usize,
    /// What to print: tables, JSON, or CSV (canonical models: one row per tube and order).
    #[arg(long, value_enum, default_value_t)]
    pub format: Format,
    /// How the model's functions run (the analysis itself evaluates the symbolic derivatives).
    #[arg(long, value_enum, default_value_t)]
    pub backend: BackendArg,
    #[command(flatten)]
    pub families: FamiliesOpt,
    /// Dissipative planar models: domain-of-attraction options.
    #[command(flatten)]
    pub attraction: super::attraction::AttractionArgs,
    #[command(flatten)]
    pub canonical: CanonicalArgs,
}

/// Arguments of `lasalle stability` for canonical models (see `docs/stability.md`).
#[derive(Args, Debug)]
pub struct CanonicalArgs {
    /// Canonical models: bound the time to go from distance d0 to d1 of the equilibrium;
    /// repeatable (one table per tube).
    #[arg(long, value_name = "D0,D1")]
    pub time_bound: Vec<String>,
    /// Canonical models: the highest normal-form order N of the bounds (orders 4, 6, …, N).
    /// Without it the order is searched: N = 4, 6, … until every bound stops growing (at most
    /// 60), and the optimal order is reported.
    #[arg(long, value_parser = value::size, allow_hyphen_values = true)]
    pub order: Option<usize>,
    /// Canonical models: the largest inner radius d0 whose orbits stay within d1 = k·d0
    /// (`--outer-ratio`) for at least this time; repeatable.
    #[arg(long, value_name = "T", value_parser = value::positive, allow_hyphen_values = true)]
    pub for_time: Vec<f64>,
    /// With --for-time: the ratio k = d1/d0 of the tube (default 2).
    #[arg(
        long,
        value_name = "K",
        allow_hyphen_values = true,
        requires = "for_time"
    )]
    pub outer_ratio: Option<f64>,
    /// Canonical models: the remainder degree M (default min(2N, N + 8) for each order N).
    #[arg(long, value_name = "M", value_parser = value::size, allow_hyphen_values = true)]
    pub remainder_degree: Option<usize>,
    /// Canonical models: how distances from the equilibrium are measured.
    #[arg(long, value_enum, default_value = "euclidean")]
    pub metric: MetricArg,
    /// Canonical models: the equilibrium, a point of the model or a Newton start x1,x2,…
    /// (default: the model's first point).
    #[arg(long, allow_hyphen_values = true, value_name = "POINT|X1,X2,…")]
    pub equilibrium: Option<String>,
    /// Canonical models: integrate orbits from each inner sphere (all action splits and
    /// phases) and compare with the bounds.
    #[arg(long)]
    pub validate: bool,
    /// With --validate: integrate to this time.
    #[arg(long, default_value_t = 200.0, value_parser = value::positive, allow_hyphen_values = true, requires = "validate")]
    pub horizon: f64,
    /// With --validate: write the figure `stability_time.svg`/`.png` into this directory.
    #[arg(long, value_name = "DIR", requires = "validate")]
    pub figure: Option<std::path::PathBuf>,
    /// Canonical models: the time budget of the order search (without --order), in seconds:
    /// no further order is started once it is spent (or when the next would overrun it), and
    /// the best order so far is reported with "still growing at N = …"; 0: no limit.
    #[arg(long, value_name = "SECONDS", default_value_t = lasalle_analysis::canonical::SEARCH_BUDGET_SECONDS, value_parser = value::non_negative, allow_hyphen_values = true)]
    pub budget: f64,
    /// Canonical models: also print a certified time (interval arithmetic through the
    /// field's Taylor models, branch and bound on the spheres) for every tube, and a
    /// certified radius for every --for-time, at the orders 4, 6, … (up to --order) while
    /// it grows, within a time budget per tube or radius.
    #[arg(long)]
    pub certified: bool,
}

/// What `lasalle stability` prints.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// Tables.
    #[default]
    Table,
    /// JSON.
    Json,
    /// CSV (canonical models).
    Csv,
}

/// The flags of each analysis, by argument id: a flag of another analysis than the model's is
/// refused, not ignored.
const LIE_POISSON_FLAGS: &[&str] = &["casimir", "range", "levels"];
const CANONICAL_FLAGS: &[&str] = &[
    "time_bound",
    "order",
    "for_time",
    "outer_ratio",
    "remainder_degree",
    "metric",
    "equilibrium",
    "validate",
    "horizon",
    "figure",
    "certified",
    "budget",
];
const ATTRACTION_FLAGS: &[&str] = &["lyapunov", "radius", "plot"];

/// `--metric`.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum MetricArg {
    /// |x − x_eq| in the model's coordinates.
    Euclidean,
    /// |A⁻¹(x − x_eq)|: linear normal coordinates (the linear flow preserves it).
    LinearNormal,
}

fn fmt_p(p: [f64; 3]) -> String {
    let c = |x: f64| {
        let x = if x.abs() < 5e-10 { 0.0 } else { x };
        format!("{x:9.5}")
    };
    format!("({}, {}, {})", c(p[0]), c(p[1]), c(p[2]))
}

fn fmt_family(f: &Family) -> String {
    let axis = (0..3).find(|&k| f.normal[k].abs() > 1.0 - 1e-9);
    let plane = match axis {
        Some(k) => format!("P{} = {:.6}", k + 1, f.offset * f.normal[k].signum()),
        None => format!(
            "({:.4}, {:.4}, {:.4})·P = {:.6}",
            f.normal[0], f.normal[1], f.normal[2], f.offset
        ),
    };
    format!(
        "circle {{{plane}}} ∩ sphere{} ({} points traced)",
        if f.closed { "" } else { " (arc)" },
        f.members
    )
}

fn print_table(rows: &[Equilibrium]) {
    println!(
        "  {:<34} {:>11} {:>11} {:>25} {:>16}  verdict",
        "P", "λ", "H", "δ²(H+λC) on T (eigs)", "linear (eigs)"
    );
    for e in rows {
        println!(
            "  {:<34} {:>11.6} {:>11.6} {:>25} {:>16}  {}",
            fmt_p(e.p),
            e.lambda,
            e.energy,
            format!("{:.6}, {:.6}", e.second_variation[0], e.second_variation[1]),
            e.spectrum.to_string(),
            e.verdict
        );
        if let Some(f) = &e.family {
            println!("      ↳ on a family of equilibria: {}", fmt_family(f));
        }
    }
}

fn print_sweep(s: &Sweep) {
    let (lo, hi) = (s.rho[0], s.rho[s.rho.len() - 1]);
    println!(
        "\nBranches of equilibria over Casimir levels ρ ∈ [{lo:.4}, {hi:.4}] ({} levels; verdict changes located by bisection, marked *):",
        s.rho.len()
    );
    for (i, b) in s.branches.iter().enumerate() {
        let family = b.segments.first().is_some_and(|g| g.family);
        println!(
            "  branch {}{}:",
            i + 1,
            if family {
                " (a circle of equilibria on each level)"
            } else {
                ""
            }
        );
        for g in &b.segments {
            let end = |r: f64, refined: bool| {
                if refined {
                    format!("{r:.6}*")
                } else {
                    format!("{r:.4}")
                }
            };
            println!(
                "    ρ ∈ [{}, {}]: {:<19} P from {} to {}",
                end(g.rho_from, g.refined[0]),
                end(g.rho_to, g.refined[1]),
                g.class.to_string(),
                fmt_p(g.p_from),
                fmt_p(g.p_to)
            );
            if let lie_poisson::Verdict::Undecided { .. } = g.verdict {
                println!("      {}", g.verdict);
            }
        }
    }
    if !s.all_equilibria.is_empty() {
        println!(
            "  the field vanishes on the whole level (every point an equilibrium) at {} of the levels",
            s.all_equilibria.len()
        );
    }
}

/// The canonical branch: normal-form verdicts and tube bounds.
fn run_canonical(args: &StabilityArgs, model: &LoadedModel) -> CliResult {
    use lasalle_analysis::canonical::{CanonicalOptions, Validation};
    use lasalle_normal_form::bound::Metric;
    use lasalle_normal_form::ModelPoint;
    let c = &args.canonical;
    // the parameters are set on the model; the normal form takes scalars only
    for p in &args.param {
        let (_, value) = p
            .split_once('=')
            .ok_or_else(|| usage(format!("invalid --param `{p}`: expected `name=value`")))?;
        let v = parse_numbers(value).map_err(|e| usage(format!("invalid --param `{p}`: {e}")))?;
        if v.len() != 1 {
            return Err(usage(format!(
                "invalid --param `{p}`: one value per parameter here"
            )));
        }
    }
    let tubes = c
        .time_bound
        .iter()
        .map(|t| match parse_numbers(t) {
            Ok(v) if v.len() == 2 => Ok((v[0], v[1])),
            Ok(v) => Err(format!(
                "invalid --time-bound `{t}`: expected D0,D1, got {} numbers",
                v.len()
            )),
            Err(e) => Err(format!("invalid --time-bound `{t}`: {e}")),
        })
        .collect::<Result<Vec<_>, _>>()
        .map_err(usage)?;
    if !(c.horizon > 0.0 && c.horizon.is_finite()) {
        return Err(usage(format!(
            "invalid --horizon {}: must be a positive finite time",
            c.horizon
        )));
    }
    if c.certified && tubes.is_empty() && c.for_time.is_empty() {
        return Err(usage(
            "--certified needs --time-bound D0,D1 or --for-time T",
        ));
    }
    if c.validate && tubes.is_empty() {
        return Err(usage("--validate needs --time-bound D0,D1"));
    }
    let point = match &c.equilibrium {
        None => ModelPoint::Auto,
        Some(s) if s.contains(',') || s.parse::<f64>().is_ok() => ModelPoint::Values(
            parse_numbers(s).map_err(|e| usage(format!("invalid --equilibrium `{s}`: {e}")))?,
        ),
        Some(name) => ModelPoint::Named(name.clone()),
    };
    let opts = CanonicalOptions {
        point,
        tubes,
        max_order: c
            .order
            .unwrap_or(lasalle_analysis::canonical::SEARCH_MAX_ORDER),
        optimal: c.order.is_none(),
        for_time: c.for_time.clone(),
        outer_ratio: c.outer_ratio.unwrap_or(2.0),
        remainder_degree: c.remainder_degree,
        metric: match c.metric {
            MetricArg::Euclidean => Metric::Euclidean,
            MetricArg::LinearNormal => Metric::LinearNormal,
        },
        validate: c.validate.then(|| Validation {
            horizon: c.horizon,
            ..Validation::default()
        }),
        certified: c.certified,
        budget: (c.budget > 0.0).then_some(c.budget),
        progress: None,
    };
    if let Some(dir) = &c.figure {
        if !dir.is_dir() {
            return Err(usage(format!(
                "--figure {}: not a directory",
                dir.display()
            )));
        }
    }
    opts.validate().map_err(usage)?;
    let opts = StabilityOptions {
        canonical: opts,
        ..StabilityOptions::default()
    };
    let report = streamed(model, opts, args.format == Format::Table)?;
    if let Some(dir) = &c.figure {
        super::stability_figure::write(&report, dir)?;
    }
    match args.format {
        // the report's fields in their declared order
        Format::Json => println!("{}", serde_json::to_string_pretty(&report)?),
        Format::Csv => print!("{}", report.to_csv()),
        // the head and the rows were printed as they came
        Format::Table => print!("{}", report.tubes_table()),
    }
    let failed = report.tubes.iter().filter(|t| t.failure.is_some()).count();
    if failed > 0 {
        return Err(format!(
            "{failed} of {} tubes have no bound (each says why in the report)",
            report.tubes.len()
        )
        .into());
    }
    Ok(())
}

/// The canonical analysis, its verdict and each order's rows printed as they come (`table`),
/// with a progress line on standard error if it is a terminal.
fn streamed(
    model: &LoadedModel,
    mut opts: StabilityOptions,
    table: bool,
) -> Result<lasalle_analysis::canonical::CanonicalReport, Box<dyn std::error::Error>> {
    use lasalle_analysis::canonical::{row_line, search_end_line, CanonicalReport, SearchEvent};
    use lasalle_normal_form::{Progress, Stage};
    let bar = super::progress::spinner();
    let line = bar.clone();
    opts.canonical.progress = Some(Progress(std::sync::Arc::new(move |stage| {
        if let Stage::Degree {
            degree,
            order,
            precision,
        } = stage
        {
            line.set_message(format!(
                "normal form of order {order} ({precision}): degree {degree}"
            ));
        }
    })));
    let tubes = opts.canonical.tubes.clone();
    let many = tubes.len() > 1;
    let mut printed = vec![Vec::new(); tubes.len()];
    let mut started = false;
    let mut on_event = |e: SearchEvent<'_>| {
        let say = |text: String| bar.suspend(|| println!("{text}"));
        match e {
            SearchEvent::Start(r) if table => {
                started = true;
                say(r.head_table().trim_end().to_string());
                say(format!(
                    "\nOrders as they complete ({}):\n{}{}",
                    if many {
                        "tube = the index of --time-bound"
                    } else {
                        "the table below is repeated in full at the end"
                    },
                    if many { "  tube" } else { "" },
                    CanonicalReport::row_header()
                ));
            }
            SearchEvent::Order { order, seconds } => {
                bar.set_message(format!("order {order} ({seconds:.1} s so far)"))
            }
            SearchEvent::Row { tube, row } if table => {
                printed[tube].push(row.clone());
                let label = if many {
                    format!("  {:>4}", tube + 1)
                } else {
                    String::new()
                };
                say(format!("{label}{}", row_line(row)));
            }
            SearchEvent::TubeEnd { tube, end } if table => {
                if let Some(s) = search_end_line(Some(end), None, &printed[tube]) {
                    let (d0, d1) = tubes[tube];
                    say(format!("  tube {d0:e} → {d1:e}: {s}"));
                }
            }
            _ => {}
        }
    };
    let report = stability::canonical_with(model, &opts, &mut on_event);
    bar.finish_and_clear();
    let report = report?;
    // without a search (no tube) no event printed the head
    if table && !started {
        print!("{}", report.head_table());
    }
    Ok(report)
}

/// Runs `lasalle stability`.
pub fn run(args: &StabilityArgs, given: &Given) -> CliResult {
    let (mut model, stem) = load_with(&args.model, args.backend.into(), args.families.into())?;
    for p in &args.param {
        apply_param(&mut model, p).map_err(usage)?;
    }
    let name = model.model_name();
    let refuse = |flags: &[&str], analysis: &str| {
        given.refuse(
            flags,
            &format!("does not apply: `{name}` gets the {analysis} analysis (see `lasalle stability --help`)"),
        )
    };
    // one match on the structure chooses the analysis
    let kind = StabilityKind::of(&model).map_err(|e| e.message("with --at x1,x2"))?;
    match kind {
        StabilityKind::LiePoisson => {
            refuse(CANONICAL_FLAGS, "Lie–Poisson (energy–Casimir)")?;
            refuse(ATTRACTION_FLAGS, "Lie–Poisson (energy–Casimir)")?;
        }
        StabilityKind::Canonical => {
            refuse(LIE_POISSON_FLAGS, "canonical (normal-form)")?;
            refuse(ATTRACTION_FLAGS, "canonical (normal-form)")?;
            refuse(
                &["at"],
                "canonical (normal-form): give the point with --equilibrium",
            )?;
            return run_canonical(args, &model);
        }
        // no Hamiltonian structure: the domain of attraction of a dissipative planar field
        StabilityKind::Attraction => {
            let analysis =
                "domain-of-attraction (a dissipative field without Hamiltonian structure)";
            refuse(LIE_POISSON_FLAGS, analysis)?;
            refuse(CANONICAL_FLAGS, analysis)?;
            if args.format == Format::Csv {
                return Err(usage(format!(
                    "--format csv: the {analysis} analysis prints tables or JSON"
                )));
            }
            return super::attraction::run(
                &model,
                &stem,
                args.at.as_deref(),
                args.format == Format::Json,
                &args.attraction,
            );
        }
    }
    if args.format == Format::Csv {
        return Err(usage(
            "--format csv: the Lie–Poisson analysis prints tables or JSON",
        ));
    }
    let at = match &args.at {
        Some(at) => {
            let v = parse_numbers(at).map_err(|e| usage(format!("invalid --at `{at}`: {e}")))?;
            if v.len() != 3 {
                return Err(usage(format!(
                    "--at needs 3 numbers P1,P2,P3, got {}",
                    v.len()
                )));
            }
            Some(v)
        }
        None => None,
    };
    let range = match &args.range {
        Some(r) => {
            let bad = || {
                usage(format!(
                    "invalid --range `{r}`: expected `a:b` with 0 < a < b"
                ))
            };
            let (a, b) = r.split_once(':').ok_or_else(bad)?;
            let a: f64 = a.trim().parse().map_err(|_| bad())?;
            let b: f64 = b.trim().parse().map_err(|_| bad())?;
            if !(a > 0.0 && b > a && b.is_finite()) {
                return Err(bad());
            }
            Some((a, b))
        }
        None => None,
    };
    let opts = StabilityOptions {
        casimir: args.casimir,
        at,
        range,
        levels: args.levels,
        ..StabilityOptions::default()
    };
    let report = stability::lie_poisson(&model, &stem, &opts)?;
    if args.format == Format::Json {
        println!("{}", serde_json::to_string_pretty(&report.to_json())?);
        return Ok(());
    }
    let pstr: Vec<String> = report
        .params
        .iter()
        .map(|(n, v)| {
            let v: Vec<String> = v.iter().map(|x| x.to_string()).collect();
            format!("{n} = {}", v.join(","))
        })
        .collect();
    println!(
        "{} ({stem}): Lie–Poisson on so(3)*, Ṗ = P × ∇H; {}",
        report.model,
        pstr.join(", ")
    );
    println!(
        "Casimir C = ½|P|²; equilibria ∇H + λP = 0; δ² = second variation of H + λC on the tangent plane of the sphere |P| = ρ; linear = eigenvalues of the field's Jacobian there."
    );
    if let Some(e) = &report.point {
        println!("\nThe equilibrium P = {} (|P| = {:.6}):", fmt_p(e.p), e.rho);
        print_table(std::slice::from_ref(e));
    }
    if let Some(l) = &report.level {
        if l.all_equilibria {
            println!(
                "\nOn the Casimir level |P| = {:.6} the field vanishes: every point is an equilibrium (trivially stable).",
                l.rho
            );
        } else {
            println!("\nEquilibria on the Casimir level |P| = {:.6}:", l.rho);
            print_table(&l.equilibria);
        }
    }
    print_sweep(&report.sweep);
    Ok(())
}
