//! `lasalle infante <model> --alpha α₁,…,αₙ --c c₁,…,cₙ --t-end T`: Infante's criterion
//! (Theorem 2.1 of "Stability criteria for n-th order, homogeneous linear differential
//! equations") on a model in companion form with coefficient functions of a clock state. It
//! reads p₁(t) … pₙ(t) off the model symbolically, evaluates the criterion's w(t) and its
//! parts on a grid of [t₀, T] and reports its smallest value: w ≥ δ > 0 there decides
//! asymptotic stability when the interval covers the coefficients' behaviour for all t ≥ τ
//! (a period of periodic coefficients; Corollary 2.1).

use std::fmt::Write as _;

use clap::Args;
use lasalle_analysis::infante::criterion::Criterion;
use lasalle_analysis::infante::equation::{assess, CompanionEquation};
use serde_json::json;

use super::args::parse_param;
use super::load::model_text;
use super::{model_failure, usage, value, CliResult};

/// Arguments of `lasalle infante`.
#[derive(Args, Debug)]
pub struct InfanteArgs {
    /// The model: a path to a model file or the name of a built-in model, in companion form
    /// (d/dt x₁ = x₂, …, d/dt xₙ = −pₙ(t)x₁ − … − p₁(t)xₙ, a clock state with d/dt c = 1 for t).
    pub model: String,
    /// The constants α₁,…,αₙ (Routh–Hurwitz) the coefficients are measured from.
    #[arg(long, value_name = "A1,…,AN", allow_hyphen_values = true)]
    pub alpha: String,
    /// C's diagonal c₁,…,cₙ: non-negative with exactly one zero, at the position i of the
    /// theorem.
    #[arg(long, value_name = "C1,…,CN")]
    pub c: String,
    /// Start of the interval of t.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub t_start: f64,
    /// End of the interval of t.
    #[arg(long, value_parser = value::end_time, allow_hyphen_values = true)]
    pub t_end: f64,
    /// Grid intervals on [t-start, t-end] (the smallest w is refined between grid points).
    #[arg(long, default_value_t = 1000, value_parser = value::size)]
    pub samples: usize,
    /// Set a parameter, `name=value`; repeatable.
    #[arg(long, value_name = "NAME=V")]
    pub param: Vec<String>,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

fn numbers(flag: &str, text: &str) -> CliResult<Vec<f64>> {
    text.split(',')
        .map(|v| match v.trim().parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(x),
            _ => Err(usage(format!(
                "`--{flag} {text}`: `{v}` is not a finite number"
            ))),
        })
        .collect()
}

/// Runs `lasalle infante`.
pub fn run(args: &InfanteArgs) -> CliResult {
    if args.t_end <= args.t_start {
        return Err(usage(format!(
            "--t-end {} must be after --t-start {}",
            args.t_end, args.t_start
        )));
    }
    let (path, _, text) = model_text(&args.model)?;
    let model = lasalle_codegen::lower_source(&path, &text).map_err(model_failure)?;
    let mut params = model.default_params();
    for p in &args.param {
        let (name, values) = parse_param(p).map_err(usage)?;
        let slot = model.param(&name).ok_or_else(|| {
            usage(format!(
                "--param {p}: `{}` has no parameter `{name}`",
                model.name
            ))
        })?;
        if values.len() != slot.slots() {
            return Err(usage(format!(
                "--param {p}: `{name}` has {} slots, {} values given",
                slot.slots(),
                values.len()
            )));
        }
        params[slot.offset..slot.offset + values.len()].copy_from_slice(&values);
    }
    let eq = CompanionEquation::from_model(&model, &params).map_err(model_failure)?;
    let (alpha, c) = (numbers("alpha", &args.alpha)?, numbers("c", &args.c)?);
    if alpha.len() != eq.order() {
        return Err(usage(format!(
            "--alpha has {} values; `{}` is of order n = {} (states {})",
            alpha.len(),
            eq.name,
            eq.order(),
            eq.names.join(", ")
        )));
    }
    let criterion = Criterion::new(&alpha, &c).map_err(usage)?;
    let a = assess(
        &eq,
        &criterion,
        &params,
        (args.t_start, args.t_end),
        args.samples,
    );
    if args.json {
        let out = json!({
            "model": eq.name, "order": eq.order(), "alpha": alpha, "c": c, "i": criterion.i,
            "B": criterion.b, "beta": criterion.beta(),
            "coefficients": (1..=eq.order()).map(|k| eq.coefficient_text(k)).collect::<Vec<_>>(),
            "slots": eq.legend,
            "t": a.t, "p": a.p, "w": a.terms.iter().map(|t| t.w).collect::<Vec<_>>(),
            "min_w": a.min_w, "t_min": a.t_min, "holds": a.holds(),
        });
        println!("{}", serde_json::to_string_pretty(&out)?);
        return Ok(());
    }
    println!("{}", report(args, &eq, &criterion, &a));
    Ok(())
}

fn report(
    args: &InfanteArgs,
    eq: &CompanionEquation,
    c: &Criterion,
    a: &lasalle_analysis::infante::equation::Assessment,
) -> String {
    let n = eq.order();
    let mut s = format!(
        "{}: x⁽ⁿ⁾ + p₁(t)x⁽ⁿ⁻¹⁾ + … + pₙ(t)x = 0, n = {n}, in the states {}{}\n",
        eq.name,
        eq.names.join(", "),
        eq.clock_name
            .as_ref()
            .map_or(String::new(), |k| format!(", t the clock {k}"))
    );
    for k in 1..=n {
        let _ = writeln!(s, "  p{k}(t) = {}", eq.coefficient_text(k));
    }
    let _ = writeln!(s, "  ({})", eq.legend);
    let _ = writeln!(
        s,
        "α = {:?}, C = diag{:?}, i = {}, β_n{} = {:.6}\nB = {:?}\n",
        c.alpha,
        c.c,
        c.i,
        c.i,
        c.beta(),
        c.b
    );
    let _ = writeln!(
        s,
        "w = 2β η_{{n+1−i}} − Σ_{{j<i}} (β u_j − η_{{n+1−i}} b_j)²/c_j − Σ_{{j>i}} (…)²/c_j  (2.20), η_k = p_k(t) − α_k\n"
    );
    let _ = writeln!(s, "| t | p(t) | 2βη | upper squares | lower squares | w |");
    let _ = writeln!(s, "| --- | --- | --- | --- | --- | --- |");
    let step = (a.t.len() / 10).max(1);
    for k in (0..a.t.len()).step_by(step) {
        let t = &a.terms[k];
        let _ = writeln!(
            s,
            "| {:.4} | {:?} | {:.6} | {:.6} | {:.6} | {:.6} |",
            a.t[k],
            a.p[k]
                .iter()
                .map(|x| (x * 1e6).round() / 1e6)
                .collect::<Vec<_>>(),
            t.linear,
            t.upper,
            t.lower,
            t.w
        );
    }
    let _ = write!(
        s,
        "\nmin w = {:.9} at t = {:.6} on [{}, {}]: ",
        a.min_w, a.t_min, args.t_start, args.t_end
    );
    if a.holds() {
        let _ = write!(
            s,
            "w ≥ δ = {:.6} > 0, so the origin is asymptotically stable if the coefficients stay \
             on [{}, {}]'s values for all t (Theorem 2.1; Corollary 2.1 from some τ on)",
            a.min_w, args.t_start, args.t_end
        );
    } else {
        let _ = write!(
            s,
            "w ≤ 0 there: this α and C do not decide (the criterion is sufficient, not necessary; try other α's or C)"
        );
    }
    s
}
