//! `lasalle section <model> --event NAME [--grid name=a:b:n …] [--energy E --solve name]
//! --axes a,b --t-end T`: a Poincaré section. Many initial conditions (a grid of state
//! components, or the rows of a CSV list), optionally put on an energy level by solving
//! H(x) = E for one missing component (a momentum), are integrated across the machine's cores
//! (the library's ensemble), and every crossing of the model's event `NAME` is a point of the
//! section: `section.csv` (orbit, t, state, invariants) and a figure of two components
//! (`section.svg`, `section.png`).

use std::path::PathBuf;

use clap::Args;
use lasalle::events::brent;
use lasalle::{
    simulate_many, Declared, Init, Invariants, LoadedModel, Member, Method, ModelInfo, ModelSource,
    Parameters, RunError, RunSpec,
};

use super::args::{parse_grid_axis, parse_param};
use super::load::{model_text, BackendArg, FamiliesOpt};
use super::plot::{write_figure, Chart, Style};
use super::run::refuse_inapplicable;
use super::{usage, value, CliResult, Given};

/// Arguments of `lasalle section`.
#[derive(Args, Debug)]
pub struct SectionArgs {
    /// The model: a path to a model file or the name of a built-in model.
    pub model: String,
    /// The event whose crossings make the section (`event NAME: g = 0 …;` in the model file).
    #[arg(long)]
    pub event: String,
    /// An axis of initial conditions: `name=start:stop:count` or `name=v1,v2,…`, name a
    /// component of the state as the trace names it (`q[1]`); repeatable, the initial
    /// conditions are their Cartesian product, set on the state of --init.
    #[arg(long, value_name = "NAME=SPEC", allow_hyphen_values = true)]
    pub grid: Vec<String>,
    /// A CSV file with one initial condition per row, its header naming state components;
    /// instead of, or crossed with, --grid.
    #[arg(long, value_name = "FILE")]
    pub list: Option<PathBuf>,
    /// The state the grid's components are set on: a point of the model or comma-separated
    /// numbers; default: the model's first point.
    #[arg(long, allow_hyphen_values = true)]
    pub init: Option<String>,
    /// Put every initial condition on the level set {integral = E} (the Hamiltonian `H`
    /// unless --integral names another) by solving for the component --solve: the root above
    /// the minimum of the integral in that component (for a kinetic energy, the positive
    /// momentum). Conditions that cannot reach the level are skipped and counted.
    #[arg(long, allow_hyphen_values = true)]
    pub energy: Option<f64>,
    /// The component solved for with --energy (`p[0]`).
    #[arg(long, value_name = "NAME")]
    pub solve: Option<String>,
    /// The scalar integral whose level --energy sets (default: `H`).
    #[arg(long, default_value = "H")]
    pub integral: String,
    /// The two state components plotted, `a,b` (`q[1],p[1]`).
    #[arg(long, value_name = "A,B")]
    pub axes: String,
    /// The method of every orbit (as `lasalle run -m`).
    #[arg(long, short, default_value = "taylor")]
    pub method: String,
    /// Step size of fixed-step methods; the first step of adaptive ones.
    #[arg(long, value_parser = value::positive, allow_hyphen_values = true)]
    pub dt: Option<f64>,
    /// Each orbit's end time (negative: backwards).
    #[arg(long, value_parser = value::end_time, allow_hyphen_values = true)]
    pub t_end: f64,
    /// Relative tolerance of adaptive methods (the Taylor tolerance ε). Default 1e-13.
    #[arg(long, value_parser = value::positive, allow_hyphen_values = true)]
    pub rtol: Option<f64>,
    /// Absolute tolerance of dopri5 (default: --rtol).
    #[arg(long, value_parser = value::positive, allow_hyphen_values = true)]
    pub atol: Option<f64>,
    /// Set a parameter, `name=value[,value…]`; repeatable.
    #[arg(long, value_name = "NAME=V")]
    pub param: Vec<String>,
    /// Worker threads (default: all cores).
    #[arg(long, value_parser = value::size)]
    pub threads: Option<usize>,
    /// How the model's functions run.
    #[arg(long, value_enum, default_value_t)]
    pub backend: BackendArg,
    #[command(flatten)]
    pub families: FamiliesOpt,
    /// The figure's title (default: the model, the event and the level).
    #[arg(long)]
    pub title: Option<String>,
    /// Output directory (default: out/<model>-section-<event>/).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// No report on standard output.
    #[arg(long, short)]
    pub quiet: bool,
}

/// The index of the state component `name`, or a message listing them.
fn component(names: &[String], name: &str, flag: &str) -> Result<usize, String> {
    names.iter().position(|c| c == name).ok_or_else(|| {
        format!(
            "{flag} `{name}` is not a component of the state; components: {}",
            names.join(", ")
        )
    })
}

/// The initial conditions: (component, value) pairs per orbit.
fn conditions(args: &SectionArgs, names: &[String]) -> Result<Vec<Vec<(usize, f64)>>, String> {
    let mut rows: Vec<Vec<(usize, f64)>> = vec![Vec::new()];
    for axis in &args.grid {
        let (name, values) = parse_grid_axis(axis)?;
        let i = component(names, &name, "--grid")?;
        rows = rows
            .into_iter()
            .flat_map(|r| {
                values.iter().map(move |&v| {
                    let mut r = r.clone();
                    r.push((i, v));
                    r
                })
            })
            .collect();
    }
    if let Some(path) = &args.list {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("cannot read --list {}: {e}", path.display()))?;
        let mut lines = text.lines().filter(|l| !l.trim().is_empty());
        let header: Vec<usize> = lines
            .next()
            .ok_or_else(|| format!("--list {}: empty file", path.display()))?
            .split(',')
            .map(|n| component(names, n.trim(), "--list column"))
            .collect::<Result<_, _>>()?;
        let mut listed = Vec::new();
        for (k, line) in lines.enumerate() {
            let values: Vec<f64> = line
                .split(',')
                .map(|v| v.trim().parse::<f64>().ok().filter(|v| v.is_finite()))
                .collect::<Option<_>>()
                .filter(|v: &Vec<f64>| v.len() == header.len())
                .ok_or_else(|| {
                    format!(
                        "--list {} line {}: expected {} finite numbers",
                        path.display(),
                        k + 2,
                        header.len()
                    )
                })?;
            listed.push(header.iter().copied().zip(values).collect::<Vec<_>>());
        }
        rows = rows
            .into_iter()
            .flat_map(|r| {
                listed.iter().map(move |l| {
                    let mut r = r.clone();
                    r.extend(l);
                    r
                })
            })
            .collect();
    }
    Ok(rows)
}

/// Solves f(x) = e for component `k` of `x`, f the invariant component `inv`: the root above
/// the minimum of f along that component (found from the parabola through three values, exact
/// for a quadratic kinetic energy), bracketed by doubling and refined by Brent's method.
/// `None` if the level lies below the minimum or f does not grow along the component.
fn solve_level(model: &LoadedModel, x: &mut [f64], k: usize, inv: usize, e: f64) -> Option<f64> {
    let mut f = vec![0.0; model.invariant_dim()];
    let mut state = x.to_vec();
    let mut h = |s: f64| {
        state[k] = s;
        model.invariants(&state, &mut f);
        f[inv] - e
    };
    let (a, b, c) = (h(-1.0), h(0.0), h(1.0));
    let curvature = 0.5 * (a + c) - b;
    // NaN fails too
    if curvature.is_nan() || curvature <= 0.0 {
        return None;
    }
    let vertex = -(c - a) / (4.0 * curvature);
    let low = h(vertex);
    if low.is_nan() || low > 0.0 {
        return None;
    }
    let mut d = 1.0;
    let mut high = h(vertex + d);
    while high < 0.0 {
        d *= 2.0;
        if d > 1e8 {
            return None;
        }
        high = h(vertex + d);
    }
    let s = brent(&mut h, vertex, vertex + d, low, high, 0.0);
    x[k] = s;
    Some(s)
}

/// Runs `lasalle section`.
pub fn run(args: &SectionArgs, given: &Given) -> CliResult {
    let method: Method = args.method.parse().map_err(usage)?;
    refuse_inapplicable(method, given)?;
    if args.energy.is_some() != args.solve.is_some() {
        return Err(usage(
            "--energy and --solve go together: the level, and the component solved for to reach it",
        ));
    }
    let (path, stem, text) = model_text(&args.model)?;
    let source = ModelSource::new(path, text, args.backend.into()).families(args.families.into());
    let mut model: LoadedModel = source.load().map_err(super::model_failure)?;
    let mut params = Vec::new();
    for p in &args.param {
        let (name, values) = parse_param(p).map_err(usage)?;
        model.set_param(&name, &values).map_err(usage)?;
        params.push((name, values));
    }
    let name = model.model_name();
    let event = model
        .events()
        .iter()
        .position(|e| e.name == args.event)
        .ok_or_else(|| {
            let declared: Vec<&str> = model.events().iter().map(|e| e.name).collect();
            usage(format!(
                "`{name}` declares no event `{}`; {}",
                args.event,
                if declared.is_empty() {
                    "it declares none: add `event NAME: g = 0;` to the model file".to_string()
                } else {
                    format!("its events: {}", declared.join(", "))
                }
            ))
        })?;
    let names = lasalle::component_names(model.state_slots());
    let (a, b) = args.axes.split_once(',').ok_or_else(|| {
        usage(format!(
            "--axes `{}`: give two components, `a,b`",
            args.axes
        ))
    })?;
    let axes = [
        component(&names, a.trim(), "--axes").map_err(usage)?,
        component(&names, b.trim(), "--axes").map_err(usage)?,
    ];
    let base = match &args.init {
        Some(init) => lasalle::initial_state(&model, init).map_err(usage)?,
        None => match model.point_names().first() {
            Some(p) => model.point(p).expect("a declared point"),
            None => vec![0.0; model.state_dim()],
        },
    };
    let level = match (&args.solve, args.energy) {
        (Some(solve), Some(e)) => {
            let k = component(&names, solve, "--solve").map_err(usage)?;
            let inv = model
                .invariant_infos()
                .iter()
                .find(|i| i.slot.name == args.integral && i.slot.shape.len() == 1)
                .map(|i| i.slot.offset)
                .ok_or_else(|| {
                    usage(format!(
                        "`{name}` has no scalar integral `{}` for --energy (name one with --integral)",
                        args.integral
                    ))
                })?;
            Some((k, inv, e))
        }
        _ => None,
    };
    let rows = conditions(args, &names).map_err(usage)?;
    let mut x0s = Vec::new();
    let mut skipped = 0usize;
    for row in &rows {
        let mut x = base.clone();
        for &(i, v) in row {
            x[i] = v;
        }
        if let Some((k, inv, e)) = level {
            if solve_level(&model, &mut x, k, inv, e).is_none() {
                skipped += 1;
                continue;
            }
        }
        x0s.push(x);
    }
    if x0s.is_empty() {
        return Err(usage(format!(
            "none of the {} initial conditions reaches the level {} = {}",
            rows.len(),
            args.integral,
            args.energy.unwrap_or(f64::NAN)
        )));
    }
    let rtol = args.rtol.unwrap_or(1e-13);
    let mut builder = RunSpec::builder()
        .method(method)
        .t_end(args.t_end)
        .every(u64::MAX);
    if method.is_adaptive() {
        builder = builder.rtol(rtol);
        if !method.is_taylor() {
            builder = builder.atol(args.atol.unwrap_or(rtol));
        }
    }
    if let Some(dt) = args.dt {
        builder = builder.dt(dt);
    }
    let spec = builder.build().map_err(|e| match e {
        RunError::Missing("dt") => usage(format!("give --dt: `{method}` takes fixed steps")),
        e => usage(e),
    })?;
    let members: Vec<Member> = x0s
        .iter()
        .map(|x| {
            params
                .iter()
                .fold(Member::new(Init::State(x.clone())), |m, (n, v)| {
                    m.param(n.as_str(), v.clone())
                })
        })
        .collect();
    let threads = args
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let ensemble = simulate_many(&source, &members, &spec, threads, 1).map_err(usage)?;

    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("out/{stem}-section-{}", args.event)));
    std::fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let inv_names = {
        let mut n = lasalle::component_names(
            &model
                .invariant_infos()
                .iter()
                .map(|i| i.slot)
                .collect::<Vec<_>>(),
        );
        n.resize_with(model.invariant_dim(), String::new);
        n
    };
    let mut csv = lasalle::Csv::new(std::io::BufWriter::new(
        std::fs::File::create(dir.join("section.csv"))
            .map_err(|e| format!("cannot create {}: {e}", dir.join("section.csv").display()))?,
    ));
    csv.record(
        ["orbit".to_string(), "t".to_string()]
            .into_iter()
            .chain(names.iter().cloned())
            .chain(inv_names.iter().cloned()),
    )?;
    let event_name = model.events()[event].name;
    let (mut px, mut py) = (Vec::new(), Vec::new());
    let (mut points, mut failed) = (0usize, Vec::new());
    let (mut level_error, mut plane_error) = (0.0f64, 0.0f64);
    let mut g = vec![0.0; model.events().len()];
    for (orbit, result) in ensemble.recordings.iter().enumerate() {
        let rec = match result {
            Ok(rec) => rec,
            Err(e) => {
                failed.push(format!("orbit {orbit}: {e}"));
                continue;
            }
        };
        if let Some(e) = &rec.failure {
            failed.push(format!("orbit {orbit} (x0 = {:?}): {e}", x0s[orbit]));
        }
        for hit in rec.events_named(event_name) {
            csv.record(
                [orbit.to_string(), hit.t.to_string()]
                    .into_iter()
                    .chain(hit.x.iter().chain(&hit.invariants).map(f64::to_string)),
            )?;
            px.push(hit.x[axes[0]]);
            py.push(hit.x[axes[1]]);
            points += 1;
            if let Some((_, inv, e)) = level {
                level_error = level_error.max((hit.invariants[inv] - e).abs());
            }
            model.event_values(&hit.x, hit.t, &mut g);
            plane_error = plane_error.max(g[event].abs());
        }
    }
    csv.into_inner()?;
    let title = args.title.clone().unwrap_or_else(|| match args.energy {
        Some(e) => format!("{name}: section `{event_name}`, {} = {e}", args.integral),
        None => format!("{name}: section `{event_name}`"),
    });
    let mut chart = Chart::new(&title, &names[axes[0]], &names[axes[1]], false);
    chart.add(
        &format!("{points} points, {} orbits", x0s.len()),
        px,
        py,
        0,
        Style::Dots,
    );
    write_figure(&dir, "section", &[chart], (1, 1), (900, 820))?;
    if !args.quiet {
        println!(
            "{name} section `{event_name}`: {} orbits to t = {} ({method}), {points} points{}",
            x0s.len(),
            args.t_end,
            if skipped > 0 {
                format!(", {skipped} initial conditions below the level skipped")
            } else {
                String::new()
            }
        );
        if level.is_some() {
            println!(
                "  max |{} − E| at the points: {level_error:.3e}",
                args.integral
            );
        }
        println!("  max |g| at the points: {plane_error:.3e}");
        println!(
            "wrote {0}/section.csv, {0}/section.svg and {0}/section.png",
            dir.display()
        );
    }
    if !failed.is_empty() {
        return Err(format!(
            "{} of {} orbits failed (their points up to the failure are in section.csv):\n  {}",
            failed.len(),
            x0s.len(),
            failed.join("\n  ")
        )
        .into());
    }
    Ok(())
}
