//! `lasalle sweep <model> --grid name=a:b:n … [--shard i/n] --out table.csv`: one run per point
//! of a grid (or per row of a list) over parameters and initial-state components, in parallel
//! across the machine's cores, written as one table; `--shard i/n` runs every n-th row starting
//! at i, so a cluster's array jobs (Slurm `--array=0-9` with `--shard $SLURM_ARRAY_TASK_ID/10`,
//! PBS, `xargs -P`) split a sweep across machines, and `lasalle sweep-merge` joins the shards'
//! tables, checking that every row is there exactly once.
//!
//! The runs are the library's ensemble ([`lasalle::simulate_many`]): one model per thread, and
//! within a thread rows that share their parameters together in lanes (`--lanes`: fixed-step
//! Runge–Kutta methods one kernel call per stage for up to `--lanes` states, the Taylor method
//! one call of its recurrences for two orbits at a time), each row's result bitwise the one it
//! gets alone.

use std::collections::BTreeMap;
use std::path::PathBuf;

use clap::Args;
use lasalle::{
    simulate_many, GainPolicy, Init, LoadedModel, Member, Method, ModelInfo, ModelSource,
    Recording, RunError, RunSpec,
};

use super::args::parse_grid_axis;
use super::load::{model_text, BackendArg, FamiliesOpt};
use super::run::refuse_inapplicable;
use super::{usage, value, CliResult, Given};

/// Arguments of `lasalle sweep`.
#[derive(Args, Debug)]
pub struct SweepArgs {
    /// The model: a path to a model file or the name of a built-in model.
    pub model: String,
    /// An axis: `name=start:stop:count` (count values, ends included) or `name=v1,v2,…`, where
    /// name is a scalar parameter or a component of the initial state as the trace names it
    /// (`x`, `q[0]`, `R[0,1]`); repeatable, the grid is their Cartesian product.
    #[arg(long, value_name = "NAME=SPEC", allow_hyphen_values = true)]
    pub grid: Vec<String>,
    /// A CSV file with one run per row; its header names scalar parameters and state
    /// components (without commas: give matrix components with `--grid`). Instead of, or
    /// crossed with, `--grid`.
    #[arg(long, value_name = "FILE")]
    pub list: Option<PathBuf>,
    /// The method of every run (as `lasalle run -m`).
    #[arg(long, short, default_value = "dopri5")]
    pub method: String,
    /// Step size of fixed-step methods (required); the first step of adaptive ones (default:
    /// chosen by the method), as in `lasalle run`.
    #[arg(long, value_parser = value::positive, allow_hyphen_values = true)]
    pub dt: Option<f64>,
    /// End time (the runs start at t = 0; a negative one integrates backwards).
    #[arg(long, value_parser = value::end_time, allow_hyphen_values = true)]
    pub t_end: f64,
    /// The initial state: a point of the model (evaluated with each row's parameters) or
    /// comma-separated numbers; default: the model's first point.
    #[arg(long, allow_hyphen_values = true)]
    pub init: Option<String>,
    /// Gains of feedback methods, as in `lasalle run`.
    #[arg(long, default_value = "default", allow_hyphen_values = true)]
    pub gains: String,
    /// Relative tolerance of adaptive methods, as in `lasalle run` (default 1e-10).
    #[arg(long, value_parser = value::positive, allow_hyphen_values = true)]
    pub rtol: Option<f64>,
    /// Absolute tolerance of adaptive methods, as in `lasalle run` (default 1e-10).
    #[arg(long, value_parser = value::positive, allow_hyphen_values = true)]
    pub atol: Option<f64>,
    /// A run has diverged when an invariant's error exceeds this many times max(|f(x₀)|, 1),
    /// as in `lasalle run`.
    #[arg(long, default_value_t = lasalle::DEFAULT_MAX_DRIFT, value_parser = value::positive, allow_hyphen_values = true)]
    pub max_drift: f64,
    /// This process runs rows i, i + n, i + 2n, … of the sweep (0 ≤ i < n).
    #[arg(long, value_name = "I/N")]
    pub shard: Option<String>,
    /// Threads (default: all cores).
    #[arg(long, value_parser = value::size, allow_hyphen_values = true)]
    pub threads: Option<usize>,
    /// Rows that share their parameters run this many at a time in lanes (methods euler, heun,
    /// rk4 and taylor; 1 runs every row alone). Results are the same either way.
    #[arg(long, default_value_t = 8, value_parser = value::size, allow_hyphen_values = true)]
    pub lanes: usize,
    /// How the model's functions run.
    #[arg(long, value_enum, default_value_t)]
    pub backend: BackendArg,
    #[command(flatten)]
    pub families: FamiliesOpt,
    /// The table to write (CSV).
    #[arg(long)]
    pub out: PathBuf,
    /// A stability map: integrate each row with a unit tangent vector (the variational
    /// equations, derived symbolically) and add the columns megno (⟨Y⟩), mle (ln‖w‖/t) and fli
    /// (sup of ln‖w‖ over the run; filled for `--indicator fli` only, whose runs locate the
    /// peaks of ln‖w‖); the map of this indicator over the first two columns of the rows is
    /// drawn into <out>.png and <out>.svg.
    #[arg(long, value_enum)]
    pub indicator: Option<super::chaos::Indicator>,
}

/// Arguments of `lasalle sweep-merge`.
#[derive(Args, Debug)]
pub struct MergeArgs {
    /// The shards' tables.
    #[arg(required = true)]
    pub tables: Vec<PathBuf>,
    /// The merged table.
    #[arg(long)]
    pub out: PathBuf,
}

/// One run of the sweep: (column, value) pairs.
type Row = Vec<(String, f64)>;

/// `i/n`.
fn parse_shard(text: &str) -> Result<(usize, usize), String> {
    let bad = || format!("invalid --shard `{text}`: expected `i/n` with 0 ≤ i < n, e.g. `3/10`");
    let (i, n) = text.split_once('/').ok_or_else(bad)?;
    let (i, n): (usize, usize) = (
        i.trim().parse().map_err(|_| bad())?,
        n.trim().parse().map_err(|_| bad())?,
    );
    if n == 0 || i >= n {
        return Err(bad());
    }
    Ok((i, n))
}

/// The rows of the sweep: for each run, (parameter, value) pairs.
fn rows(args: &SweepArgs) -> Result<Vec<Row>, String> {
    let mut rows: Vec<Row> = vec![Vec::new()];
    if let Some(path) = &args.list {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("cannot read --list {}: {e}", path.display()))?;
        let mut lines = text.lines().filter(|l| !l.trim().is_empty());
        let header: Vec<String> = lines
            .next()
            .ok_or_else(|| format!("--list {} is empty", path.display()))?
            .split(',')
            .map(|h| h.trim().to_string())
            .collect();
        let mut listed = Vec::new();
        for (k, line) in lines.enumerate() {
            let values: Vec<&str> = line.split(',').collect();
            if values.len() != header.len() {
                return Err(format!(
                    "--list {} line {}: {} values for {} columns",
                    path.display(),
                    k + 2,
                    values.len(),
                    header.len()
                ));
            }
            let mut row = Vec::new();
            for (h, v) in header.iter().zip(values) {
                let v: f64 = v
                    .trim()
                    .parse()
                    .ok()
                    .filter(|v: &f64| v.is_finite())
                    .ok_or_else(|| {
                        format!(
                            "--list {} line {}: `{v}` is not a finite number",
                            path.display(),
                            k + 2
                        )
                    })?;
                row.push((h.clone(), v));
            }
            listed.push(row);
        }
        rows = listed;
    }
    for axis in &args.grid {
        let (name, values) = parse_grid_axis(axis)?;
        let mut crossed = Vec::with_capacity(rows.len() * values.len());
        for row in rows {
            for &v in &values {
                let mut r = row.clone();
                r.push((name.clone(), v));
                crossed.push(r);
            }
        }
        rows = crossed;
    }
    Ok(rows)
}

/// What a column of the sweep sets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Column {
    /// A scalar parameter.
    Param,
    /// Component i of the initial state.
    State(usize),
}

/// What each column (in row order) names in the model.
fn columns(model: &LoadedModel, row: &[(String, f64)]) -> Result<Vec<Column>, String> {
    let components = lasalle::component_names(model.state_slots());
    row.iter()
        .map(|(name, _)| {
            if model.param_slots().iter().any(|s| s.name == name) {
                Ok(Column::Param)
            } else if let Some(i) = components.iter().position(|c| c == name) {
                Ok(Column::State(i))
            } else {
                let params: Vec<_> = model.param_slots().iter().map(|s| s.name).collect();
                Err(format!(
                    "`{name}` is neither a parameter of `{}` nor a component of its state; parameters: {}; state components: {}",
                    model.model_name(),
                    if params.is_empty() { "none".to_string() } else { params.join(", ") },
                    components.join(", ")
                ))
            }
        })
        .collect()
}

/// The run of a row: its parameters, and its initial state with the row's components.
fn member(row: &[(String, f64)], columns: &[Column], init: &Init) -> Member {
    let mut member = Member::new(init.clone());
    for ((name, v), c) in row.iter().zip(columns) {
        member = match *c {
            Column::Param => member.param(name.as_str(), [*v]),
            Column::State(i) => member.set(i, *v),
        };
    }
    member
}

/// A row of the table: the inputs, then the results, or for a run that failed empty result
/// cells (no number of a failed run reads as a result) and why, in the last column.
fn cells(index: usize, row: &[(String, f64)], t: &Recording) -> Vec<String> {
    let mut c = vec![index.to_string()];
    c.extend(row.iter().map(|(_, v)| v.to_string()));
    let results = 4 + 2 * t.blocks.len() + t.dim();
    match &t.failure {
        None => {
            c.push(t.t.last().copied().unwrap_or(0.0).to_string());
            c.push(t.steps.to_string());
            c.push(t.evaluations.to_string());
            c.push(t.wall_seconds.to_string());
            for b in 0..t.blocks.len() {
                c.push(t.final_error(b).to_string());
                c.push(t.max_error(b).to_string());
            }
            c.extend(t.last_state().iter().map(|v| v.to_string()));
            c.push(String::new());
        }
        Some(e) => {
            c.extend(std::iter::repeat_n(String::new(), results));
            // one line per row (sweep-merge reads lines); the table writer quotes it
            c.push(e.to_string().lines().collect::<Vec<_>>().join("; "));
        }
    }
    c
}

/// Runs `lasalle sweep`.
pub fn run(args: &SweepArgs, given: &Given) -> CliResult {
    let method: Method = args.method.parse().map_err(usage)?;
    let (shard, shards) = match &args.shard {
        Some(s) => parse_shard(s).map_err(usage)?,
        None => (0, 1),
    };
    refuse_inapplicable(method, given)?;
    // a sweep's table has no crossings: only `stop` events (they end runs) are watched, and
    // the peaks of ln‖w‖ for an FLI map
    let fli_map = args
        .indicator
        .is_some_and(|i| i == super::chaos::Indicator::Fli);
    let mut builder = RunSpec::builder()
        .record_events(fli_map)
        .method(method)
        .t_end(args.t_end)
        .gains(args.gains.parse::<GainPolicy>().map_err(usage)?)
        .max_drift(args.max_drift)
        .every(u64::MAX); // the initial and the final state
    if let Some(dt) = args.dt {
        builder = builder.dt(dt);
    }
    if let Some(rtol) = args.rtol {
        builder = builder.rtol(rtol);
    }
    if let Some(atol) = args.atol {
        builder = builder.atol(atol);
    }
    let spec = builder.build().map_err(|e| match e {
        RunError::Missing("dt") => usage(format!("give --dt: `{method}` takes fixed steps")),
        e => usage(e),
    })?;
    let rows = rows(args).map_err(usage)?;
    let (path, _, text) = model_text(&args.model)?;
    let mut source =
        ModelSource::new(path, text, args.backend.into()).families(args.families.into());
    let plain_dim = source.load().map_err(super::model_failure)?.dim();
    let indicator = args
        .indicator
        .map(|indicator| super::chaos::SweepIndicator { indicator });
    if let Some(ind) = &indicator {
        lasalle::run::chaos::check_method(method).map_err(usage)?;
        source = ind.source(source);
    }
    // the header, from one model
    let probe: LoadedModel = source.load().map_err(super::model_failure)?;
    let mut header = vec!["row".to_string()];
    header.extend(rows[0].iter().map(|(n, _)| n.clone()));
    header.extend(["t_final", "steps", "evaluations", "wall_seconds"].map(String::from));
    for info in probe.invariant_infos() {
        header.push(format!("final |Δ{}|", info.slot.name));
        header.push(format!("max |Δ{}|", info.slot.name));
    }
    header.extend(
        lasalle::component_names(probe.state_slots())
            .into_iter()
            .map(|n| format!("{n}(T)")),
    );
    if indicator.is_some() {
        header.extend(super::chaos::SweepIndicator::header().map(String::from));
    }
    header.push("failure".to_string());
    let columns = columns(&probe, &rows[0]).map_err(usage)?;
    drop(probe);
    // this shard's rows
    let init = match &indicator {
        Some(ind) => ind.init(args.init.as_deref(), plain_dim).map_err(usage)?,
        None => args.init.clone().map_or(Init::First, Init::Text),
    };
    let mine: Vec<(usize, &Row)> = rows
        .iter()
        .enumerate()
        .filter(|(k, _)| k % shards == shard)
        .collect();
    let members: Vec<Member> = mine
        .iter()
        .map(|(_, row)| member(row, &columns, &init))
        .collect();
    let start = std::time::Instant::now();
    let ensemble = simulate_many(
        &source,
        &members,
        &spec,
        args.threads.unwrap_or(0),
        args.lanes,
    )
    .map_err(|e| e.to_string())?;
    let runs = mine.len();
    let mut table = lasalle::Csv::new(Vec::new());
    table.record(&header)?;
    let mut failed = Vec::new();
    let mut map = Vec::new();
    for (&(k, row), recording) in mine.iter().zip(&ensemble.recordings) {
        let recording = recording
            .as_ref()
            .map_err(|e| usage(format!("row {k}: {e}")))?;
        let mut cells = cells(k, row, recording);
        if cells.last().is_some_and(|why| !why.is_empty()) {
            failed.push(k);
        }
        if let Some(ind) = &indicator {
            let at = cells.len() - 1;
            cells.splice(at..at, ind.cells(recording, plain_dim));
            map.push((row, ind.value(recording, plain_dim)));
        }
        table.record(&cells)?;
    }
    let table = table.into_inner()?;
    if let Some(dir) = args.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    }
    std::fs::write(&args.out, table)
        .map_err(|e| format!("cannot write {}: {e}", args.out.display()))?;
    let seconds = start.elapsed().as_secs_f64();
    if let (Some(ind), Some(first)) = (&indicator, map.first()) {
        super::chaos::write_sweep_map(&args.out, ind.indicator, first.0, &map, args.t_end)?;
    }
    eprintln!(
        "sweep: {} of {} runs (shard {shard}/{shards}) in {:.2} s on {} threads → {}",
        runs,
        rows.len(),
        seconds,
        ensemble.threads,
        args.out.display()
    );
    if let Some(first) = failed.first() {
        return Err(format!(
            "{} of {runs} runs failed (rows {first}, …): the table's `failure` column says why",
            failed.len()
        )
        .into());
    }
    Ok(())
}

/// Runs `lasalle sweep-merge`: the shards' rows, in order, each exactly once.
pub fn merge(args: &MergeArgs) -> CliResult {
    let mut header: Option<String> = None;
    let mut rows: BTreeMap<usize, String> = BTreeMap::new();
    for path in &args.tables {
        let text = std::fs::read_to_string(path)
            .map_err(|e| usage(format!("cannot read {}: {e}", path.display())))?;
        let mut lines = text.lines();
        let h = lines
            .next()
            .ok_or_else(|| format!("{} is empty", path.display()))?;
        match &header {
            Some(first) if first != h => {
                return Err(format!(
                    "{} has another header than the first table: not the same sweep",
                    path.display()
                )
                .into())
            }
            _ => header = Some(h.to_string()),
        }
        for line in lines.filter(|l| !l.is_empty()) {
            let k: usize = line
                .split(',')
                .next()
                .and_then(|k| k.parse().ok())
                .ok_or_else(|| {
                    format!("{}: a line without a row number: `{line}`", path.display())
                })?;
            if rows.insert(k, line.to_string()).is_some() {
                return Err(format!(
                    "row {k} appears twice (in {} and an earlier table)",
                    path.display()
                )
                .into());
            }
        }
    }
    if let Some(missing) = (0..rows.len()).find(|k| !rows.contains_key(k)) {
        return Err(format!("row {missing} is missing: did every shard finish?").into());
    }
    let mut out = header.unwrap_or_default() + "\n";
    for line in rows.values() {
        out.push_str(line);
        out.push('\n');
    }
    std::fs::write(&args.out, out)
        .map_err(|e| format!("cannot write {}: {e}", args.out.display()))?;
    eprintln!(
        "merged {} rows from {} tables → {}",
        rows.len(),
        args.tables.len(),
        args.out.display()
    );
    Ok(())
}
