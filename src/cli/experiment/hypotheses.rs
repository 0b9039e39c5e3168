//! The paper's hypotheses, computed for each §4 experiment rather than assumed: the rank of
//! Df on V⁻¹(0) (Lemma 2.4) from the model's own Jacobian at exact points of the level set,
//! the bounds on c (Lemma 3.3, Lemma 3.6's (36)) against the largest V the feedback run
//! reaches, Theorem 3.9's common-root condition (Remark 3.10) and V⁻¹(0)'s compactness, and
//! the rigid body's period T_Ω (closed form and measured). A hypothesis that fails is a
//! warning on standard error naming the lemma, and a row of the report.

use std::fmt::Write as _;

use lasalle::models::kepler::KeplerPrepared;
use lasalle::models::perturbed_kepler::PerturbedKeplerPrepared;
use lasalle::models::rigid_body::RigidBodyPrepared;
use lasalle::nalgebra::DMatrix;
use lasalle::{
    json_number as num, Control, DormandPrince, Driver, Invariants, Lyapunov, Recording,
};
use lasalle_analysis::feedback_hypotheses::{
    central_force_level_set, euler_top_period, kepler_level_set, lemma_3_3_bound, lemma_3_6_bound,
    period_from_crossings, rank_check, rigid_body_level_set, theorem_3_9, turning_radii, RankCheck,
};
use serde_json::{json, Value};

use super::sci;

/// The paper's period of Ω(t) in §4.1.
pub const PAPER_PERIOD: f64 = 6.4227;

/// The checks of one experiment: report rows, warnings, JSON.
pub struct Hypotheses {
    experiment: &'static str,
    rows: Vec<[String; 3]>,
    warnings: Vec<String>,
    json: serde_json::Map<String, Value>,
}

impl Hypotheses {
    fn new(experiment: &'static str) -> Self {
        Hypotheses {
            experiment,
            rows: Vec::new(),
            warnings: Vec::new(),
            json: serde_json::Map::new(),
        }
    }

    fn row(&mut self, hypothesis: &str, value: String, verdict: &str) {
        self.rows
            .push([hypothesis.to_string(), value, verdict.to_string()]);
    }

    fn warn(&mut self, text: String) {
        self.warnings.push(text);
    }

    /// The section of `summary.md`.
    pub fn markdown(&self) -> String {
        let mut table = super::Table::new(&["hypothesis", "computed", "verdict"]);
        for r in &self.rows {
            table.row(r.to_vec());
        }
        let mut s = String::from("\n### The paper's hypotheses\n\n");
        s.push_str(&table.markdown());
        for w in &self.warnings {
            let _ = writeln!(s, "\nwarning: {w}");
        }
        s.push('\n');
        s
    }

    /// The warnings, on standard error (also when quiet).
    pub fn print_warnings(&self) {
        for w in &self.warnings {
            eprintln!("warning: experiment {}: {w}", self.experiment);
        }
    }

    /// `summary.json`'s `hypotheses`.
    pub fn json(&self) -> Value {
        let mut m = self.json.clone();
        m.insert("warnings".into(), json!(self.warnings));
        Value::Object(m)
    }
}

/// Df at each point and ‖f(x) − f(x₀)‖∞ there, through the model's generated Jacobian.
fn rank_of<M, const N: usize, const F: usize>(
    model: &M,
    x0: &[f64; N],
    points: &[[f64; N]],
    required: usize,
) -> RankCheck
where
    M: Invariants<f64, [f64; N], [f64; F]>,
{
    let mut f0 = [0.0; F];
    model.invariants(x0, &mut f0);
    let mut jacobians = Vec::with_capacity(points.len());
    let mut residuals = Vec::with_capacity(points.len());
    for x in points {
        let mut jac = [[0.0; N]; F];
        model.invariants_jacobian(x, &mut jac);
        jacobians.push(DMatrix::from_fn(F, N, |i, j| jac[i][j]));
        let mut f = [0.0; F];
        model.invariants(x, &mut f);
        residuals.push((0..F).fold(0.0f64, |a, i| a.max((f[i] - f0[i]).abs())));
    }
    rank_check(&jacobians, &residuals, required)
}

fn rank_json(r: &RankCheck) -> Value {
    json!({
        "rows": r.shape.0,
        "columns": r.shape.1,
        "required": r.required,
        "samples": r.samples,
        "rank_min": r.rank.0,
        "rank_max": r.rank.1,
        "smallest_required_singular_value": num(r.smallest_required),
        "largest_singular_value": num(r.largest),
        "largest_singular_value_beyond": num(r.largest_beyond),
        "level_set_residual": num(r.level_set_residual),
        "holds": r.holds(),
    })
}

fn rank_text(r: &RankCheck) -> String {
    format!(
        "Df {}×{} at {} points of V⁻¹(0) (|f − f₀| ≤ {}): rank {}{}, σ_{} ≥ {}, σ₁ ≤ {}, σ_{} ≤ {}",
        r.shape.0,
        r.shape.1,
        r.samples,
        sci(r.level_set_residual),
        r.rank.0,
        if r.rank.1 != r.rank.0 {
            format!("–{}", r.rank.1)
        } else {
            String::new()
        },
        r.required,
        sci(r.smallest_required),
        sci(r.largest),
        r.required + 1,
        sci(r.largest_beyond)
    )
}

/// The largest V over the recorded states of the feedback run (its gains and targets).
fn max_v<M, const N: usize, const F: usize, const G: usize>(
    model: &M,
    x0: &[f64; N],
    gains: &[f64; G],
    run: &Recording,
) -> f64
where
    M: Lyapunov<f64, [f64; N], [f64; F], [f64; G]>,
{
    let mut target = [0.0; F];
    model.invariants(x0, &mut target);
    (0..run.len()).fold(0.0f64, |m, i| {
        let x: [f64; N] = run.state(i).try_into().unwrap_or([f64::NAN; N]);
        m.max(model.lyapunov(&x, &target, gains))
    })
}

fn bound_row(h: &mut Hypotheses, lemma: &str, terms: &str, (c, which): (f64, usize), v: f64) {
    let term = terms.split(", ").nth(which).unwrap_or("?");
    h.row(
        lemma,
        format!(
            "c < min{{{terms}}} = {} ({term}); the feedback run's max V = {}",
            sci(c),
            sci(v)
        ),
        if v < c {
            "holds: the run stays in V⁻¹([0, c])"
        } else {
            "fails"
        },
    );
    h.json.insert(
        "c_bound".into(),
        json!({"lemma": lemma, "c": num(c), "term": term, "max_v_of_feedback_run": num(v)}),
    );
    if v >= c {
        h.warn(format!(
            "{lemma}: the feedback run reaches V = {} ≥ c = {} (min{{{terms}}}), outside every sublevel set V⁻¹([0, c]) the lemma admits; the paper's convergence theorem does not cover it",
            sci(v),
            sci(c)
        ));
    }
}

/// §4.1: Lemma 2.4's rank, Lemma 3.3's c, T_Ω.
pub fn rigid_body(
    model: &RigidBodyPrepared,
    x0: &[f64; 12],
    gains: [f64; 3],
    feedback: &Recording,
) -> Hypotheses {
    let mut h = Hypotheses::new("rigid-body");
    let i = model.i;
    let w = [x0[9], x0[10], x0[11]];
    let e0 = 0.5 * (0..3).map(|k| i[k] * w[k] * w[k]).sum::<f64>();
    let mut f0 = [0.0; 13];
    model.invariants(x0, &mut f0);
    let pi0 = [f0[10], f0[11], f0[12]];
    // C = RᵀR − I is symmetric: 6 of its 9 rows are independent, r + ℓ = 6 + 1 + 3
    let points = rigid_body_level_set(i, e0, pi0, 16, 8);
    let rank = rank_of(model, x0, &points, 10);
    h.row(
        "Lemma 2.4 (rank Df = r + ℓ = 6 + 1 + 3 on V⁻¹(0); C = RᵀR − I symmetric)",
        rank_text(&rank),
        if rank.holds() { "holds" } else { "fails" },
    );
    if !rank.holds() {
        h.warn(format!(
            "Lemma 2.4: Df drops to rank {} < 10 on V⁻¹(0) (σ₁₀ = {})",
            rank.rank.0,
            sci(rank.smallest_required)
        ));
    }
    h.json.insert("lemma_2_4".into(), rank_json(&rank));
    let v = max_v(model, x0, &gains, feedback);
    bound_row(
        &mut h,
        "Lemma 3.3 (21)",
        "k₀/4, k₁|E₀|/2, k₂|π₀|²/2",
        lemma_3_3_bound(gains, e0, pi0),
        v,
    );
    period_row(&mut h, model, x0, e0, pi0);
    h
}

/// T_Ω: the closed form, and measured on a DOPRI5 orbit (upward zero crossings of Ω₂).
fn period_row(
    h: &mut Hypotheses,
    model: &RigidBodyPrepared,
    x0: &[f64; 12],
    e0: f64,
    pi0: [f64; 3],
) {
    let pi_sq = pi0.iter().map(|x| x * x).sum();
    let closed = euler_top_period(model.i, e0, pi_sq);
    let times: Vec<f64> = (1..=40_000).map(|k| k as f64 * 1e-3).collect();
    let mut omega2 = Vec::with_capacity(times.len());
    let measured = Driver::new(0.0, 40.0, 0.0)
        .run_dense(
            &mut DormandPrince::with_tolerances(1e-12, 1e-12),
            model,
            x0,
            &times,
            &mut |_i: u64, _t: f64, x: &[f64; 12]| {
                omega2.push(x[10]);
                Control::Continue
            },
        )
        .ok()
        .and_then(|_| period_from_crossings(&times, &omega2));
    let fmt = |v: Option<f64>| v.map_or("none".to_string(), |p| format!("{p:.6}"));
    let agrees = closed.is_some_and(|p| (p - PAPER_PERIOD).abs() <= 5e-5)
        && measured.is_some_and(|(p, _)| (p - PAPER_PERIOD).abs() <= 5e-5);
    h.row(
        "§4.1 T_Ω = 6.4227",
        format!(
            "closed form 4K(m)/λ: {}; measured (DOPRI5 1e-12, {} periods of Ω₂): {}",
            fmt(closed),
            measured.map_or(0, |m| m.1),
            fmt(measured.map(|m| m.0))
        ),
        if agrees {
            "holds (to the paper's 4 decimals)"
        } else {
            "fails"
        },
    );
    h.json.insert(
        "period".into(),
        json!({"paper": PAPER_PERIOD, "closed_form": closed.map(num), "measured": measured.map(|m| num(m.0))}),
    );
    if !agrees {
        h.warn(format!(
            "§4.1: T_Ω = {PAPER_PERIOD} does not match the closed form {} or the measured {}",
            fmt(closed),
            fmt(measured.map(|m| m.0))
        ));
    }
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// §4.2: Lemma 2.4's rank (which fails: L·A ≡ 0), Lemma 3.6's (36).
pub fn kepler(
    model: &KeplerPrepared,
    x0: &[f64; 6],
    gains: [f64; 2],
    feedback: &Recording,
) -> Hypotheses {
    let mut h = Hypotheses::new("kepler");
    let mu = model.mu;
    let l0 = cross([x0[0], x0[1], x0[2]], [x0[3], x0[4], x0[5]]);
    let a0 = super::kepler::lrl(x0, mu);
    let points = kepler_level_set(mu, l0, a0, 256);
    let rank = rank_of(model, x0, &points, 6);
    h.row(
        "Lemma 2.4 (rank Df = ℓ = 3 + 3 on V⁻¹(0))",
        rank_text(&rank),
        if rank.holds() {
            "holds"
        } else {
            "fails (the paper proves A2–A3 by Lemmas 3.6–3.7 instead)"
        },
    );
    if !rank.holds() {
        h.warn(format!(
            "Lemma 2.4: Df of f = (L, A) has rank {} < 6 at every sampled point of V⁻¹(0) (σ₆ ≤ {}): L·A ≡ 0 ties the rows, so the lemma cannot give A2–A3 here; the paper's Lemmas 3.6–3.7 prove them for (35) without it",
            rank.rank.1,
            sci(rank.smallest_required)
        ));
    }
    h.json.insert("lemma_2_4".into(), rank_json(&rank));
    let v = max_v(model, x0, &gains, feedback);
    bound_row(
        &mut h,
        "Lemma 3.6 (36)",
        "k₁|L₀|²/2, k₂(μ − |A₀|)²/2",
        lemma_3_6_bound(gains, mu, l0, a0),
        v,
    );
    h
}

/// §4.3: Theorem 3.9's common-root condition (Remark 3.10), V⁻¹(0)'s compactness, and the
/// rank Theorem 3.9 derives from them.
pub fn perturbed_kepler(model: &PerturbedKeplerPrepared, x0: &[f64; 6]) -> Hypotheses {
    let mut h = Hypotheses::new("perturbed-kepler");
    let (mu, delta) = (model.mu, model.delta);
    let mut f0 = [0.0; 4];
    model.invariants(x0, &mut f0);
    let (e0, l0) = (f0[0], [f0[1], f0[2], f0[3]]);
    let l0_sq: f64 = l0.iter().map(|x| x * x).sum();
    let t = theorem_3_9(mu, delta, e0, l0_sq);
    let roots = t
        .roots_58
        .iter()
        .map(|(r, res)| format!("r = {r:.6} (residual of (57) {})", sci(*res)))
        .collect::<Vec<_>>()
        .join(", ");
    h.row(
        "Theorem 3.9, Remark 3.10 (no common root r > 0 of (57), (58))",
        format!("E₀ = {e0}, |L₀|² = {l0_sq:.6}; roots of (58): {roots}"),
        match t.common_root() {
            None => "holds",
            Some(_) => "fails",
        },
    );
    if let Some(r) = t.common_root() {
        h.warn(format!(
            "Theorem 3.9: (57) and (58) have the common root r = {r} (a circular orbit): Df is not onto there and the theorem does not apply"
        ));
    }
    h.json.insert(
        "theorem_3_9".into(),
        json!({
            "roots_58": t.roots_58.iter().map(|&(r, res)| json!({"r": num(r), "residual_57": num(res)})).collect::<Vec<_>>(),
            "roots_57": t.roots_57.iter().map(|&r| num(r)).collect::<Vec<_>>(),
            "common_root": t.common_root().map(num),
            "holds": t.common_root().is_none(),
        }),
    );
    compactness(&mut h, model, x0, e0, l0, l0_sq);
    h
}

/// A band of radii, open at 0 and ∞.
fn band((a, b): (f64, f64)) -> String {
    let lo = if a > 0.0 {
        format!("[{a:.6}")
    } else {
        "(0".to_string()
    };
    let hi = if b.is_finite() {
        format!("{b:.6}]")
    } else {
        "∞)".to_string()
    };
    format!("r ∈ {lo}, {hi}")
}

/// V⁻¹(0)'s components from the turning radii, and the rank on the one of x(0).
fn compactness(
    h: &mut Hypotheses,
    model: &PerturbedKeplerPrepared,
    x0: &[f64; 6],
    e0: f64,
    l0: [f64; 3],
    l0_sq: f64,
) {
    let (mu, delta) = (model.mu, model.delta);
    let radii = turning_radii(mu, delta, e0, l0_sq);
    let r0 = (x0[0] * x0[0] + x0[1] * x0[1] + x0[2] * x0[2]).sqrt();
    // v_r² ≥ 0 on (0, r₁] and between every second pair of turning radii after it
    let mut components: Vec<(f64, f64)> = Vec::new();
    if let Some(&first) = radii.first() {
        if delta > 0.0 {
            components.push((0.0, first));
        }
        let start = if delta > 0.0 { 1 } else { 0 };
        let mut k = start;
        while k + 1 < radii.len() {
            components.push((radii[k], radii[k + 1]));
            k += 2;
        }
        if k < radii.len() && e0 >= 0.0 {
            components.push((radii[k], f64::INFINITY));
        }
    }
    let tol = 1e-9 * r0;
    let own = components
        .iter()
        .copied()
        .find(|&(a, b)| a - tol <= r0 && r0 <= b + tol && a > 0.0 && b.is_finite());
    let text = components
        .iter()
        .map(|&c| band(c))
        .collect::<Vec<_>>()
        .join(" ∪ ");
    let compact = components.len() == 1 && own.is_some();
    h.row(
        "Theorem 3.9 (V⁻¹(0) compact)",
        format!("V⁻¹(0) = {{E = E₀, L = L₀}} lies over {text}; x(0) at r = {r0}"),
        if compact {
            "holds"
        } else {
            "fails: holds for the component of x(0) only"
        },
    );
    if !compact {
        h.warn(format!(
            "Theorem 3.9: V⁻¹(0) is not compact: besides the component over {} that holds x(0) it has one over {} (δ > 0: orbits falling into the centre, |v| unbounded); the theorem's conclusion is for the compact component of x(0), separated from the rest by the gap between the turning radii",
            own.map_or("—".into(), band),
            components.iter().filter(|c| Some(**c) != own).map(|&c| band(c)).collect::<Vec<_>>().join(", ")
        ));
    }
    h.json.insert(
        "compactness".into(),
        json!({"turning_radii": radii.iter().map(|&r| num(r)).collect::<Vec<_>>(), "compact": compact}),
    );
    if let Some(band) = own {
        let points = central_force_level_set(mu, delta, e0, l0, band, 32, 16);
        let rank = rank_of(model, x0, &points, 4);
        h.row(
            "Lemma 2.4 (rank Df = ℓ = 1 + 3 on the component of x(0))",
            rank_text(&rank),
            if rank.holds() { "holds" } else { "fails" },
        );
        if !rank.holds() {
            h.warn(format!(
                "Lemma 2.4: Df drops to rank {} < 4 on V⁻¹(0) (σ₄ = {})",
                rank.rank.0,
                sci(rank.smallest_required)
            ));
        }
        h.json.insert("lemma_2_4".into(), rank_json(&rank));
    }
}
