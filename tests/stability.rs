//! `lasalle_analysis::lie_poisson` against the thesis' stability theorems (Rodgerson 2009, §4.6, 5.6, 6.6,
//! 7.6) for the four so(3)* models, on both sides of every condition, with the cases the
//! thesis leaves open decided; and dynamics: DOPRI5 from 10⁻⁴ off a stable equilibrium stays
//! within 10⁻² over t ∈ [0, 200], from 10⁻⁴ off an unstable one it leaves (distance > 0.1).
//!
//! Tolerances: equilibria to 10⁻⁸ (relative to ρ), eigenvalues and λ to 10⁻⁸ relative,
//! verdict-change levels of a sweep to 10⁻⁶.

use lasalle_analysis::lie_poisson::{
    self as stability, Equilibrium, Extremum, LiePoissonSystem, Options, Probe, Verdict, VerdictClass,
};
use lasalle::{Backend, LoadedModel, Parameters, MODEL_FILES};

fn model(stem: &str, params: &[(&str, f64)]) -> (LoadedModel, LiePoissonSystem) {
    let text = MODEL_FILES
        .iter()
        .find(|(s, _)| *s == stem)
        .unwrap_or_else(|| panic!("no model {stem}"))
        .1;
    let mut m = LoadedModel::from_source(&format!("models/{stem}.lsl"), text, Backend::Jit)
        .unwrap_or_else(|e| panic!("{stem}: {e}"));
    for (name, v) in params {
        m.set_param(name, &[*v]).unwrap();
    }
    let sys = stability::system(&m).unwrap();
    (m, sys)
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// The equilibrium at `p`: found by the level search (|P| = |p|) near p, and the same
/// verdict from the point analysis.
fn at(sys: &LiePoissonSystem, p: [f64; 3]) -> Equilibrium {
    let rho = dist(p, [0.0; 3]);
    let level = stability::analyse_level(sys, rho, &Options::default()).unwrap();
    let found = level
        .equilibria
        .iter()
        .find(|e| {
            // a degenerate (multiple) equilibrium is determined only to ~ε^⅓
            let tol = match e.verdict {
                Verdict::Undecided { .. } => 1e-4,
                _ => 1e-8,
            };
            dist(e.p, p) < tol * rho
                || e.family.as_ref().is_some_and(|f| {
                    let n = f.normal;
                    (n[0] * p[0] + n[1] * p[1] + n[2] * p[2] - f.offset).abs() < 1e-8 * rho
                })
        })
        .unwrap_or_else(|| {
            panic!(
                "{}: no equilibrium at {p:?} on |P| = {rho}; found {:?}",
                sys.name(),
                level.equilibria.iter().map(|e| e.p).collect::<Vec<_>>()
            )
        })
        .clone();
    let direct = stability::analyse_point(sys, p, &Options::default()).unwrap();
    assert_eq!(
        direct.verdict.class(),
        found.verdict.class(),
        "{}: at {p:?}",
        sys.name()
    );
    direct
}

fn stable(e: &Equilibrium) -> bool {
    matches!(e.verdict, Verdict::Stable { .. })
}

fn unstable_rate(e: &Equilibrium) -> f64 {
    match e.verdict {
        Verdict::LinearlyUnstable { rate } => rate,
        v => panic!("expected linearly unstable at {:?}, got {v:?}", e.p),
    }
}

fn close(what: &str, got: f64, want: f64) {
    assert!(
        (got - want).abs() <= 1e-8 * want.abs().max(1.0),
        "{what}: got {got}, want {want}"
    );
}

// ---- Type I (§4.6) ----------------------------------------------------------------------------

#[test]
fn type_i_theorems_4_6_1_and_4_6_2() {
    let c1 = 2.0;
    let (_, sys) = model("so3_type_i", &[("c1", c1)]);
    // Theorem 4.6.1: (M, 0, c1) stable for every M ≠ 0 (H + λC has a max), λ = −1/c1
    for m in [-3.0, -0.5, 0.25, 1.0, 4.0] {
        let e = at(&sys, [m, 0.0, c1]);
        assert_eq!(
            e.verdict,
            Verdict::Stable {
                extremum: Extremum::Max
            },
            "M = {m}"
        );
        close("λ", e.lambda, -1.0 / c1);
    }
    // Theorem 4.6.2: (0, 0, M) stable for M < 0 (min) and 0 < M < c1 (max), λ = −1/M
    for (m, ext) in [
        (-3.0, Extremum::Min),
        (-0.5, Extremum::Min),
        (0.5, Extremum::Max),
        (1.9, Extremum::Max),
    ] {
        let e = at(&sys, [0.0, 0.0, m]);
        assert_eq!(e.verdict, Verdict::Stable { extremum: ext }, "M = {m}");
        close("λ", e.lambda, -1.0 / m);
    }
    // not in the thesis: M > c1 is linearly unstable, eigenvalues ±√(M/c1 − 1)
    for m in [2.1, 3.0, 8.0] {
        let e = at(&sys, [0.0, 0.0, m]);
        close("rate", unstable_rate(&e), (m / c1 - 1.0).sqrt());
    }
    // not in the thesis: M = c1 (the pitchfork where (M', 0, c1) branches off) is degenerate;
    // H on the sphere is c1 − P2²/(2c1) − |P⊥|⁴/(8c1³) + …, a strict maximum: stable
    let e = at(&sys, [0.0, 0.0, c1]);
    assert_eq!(
        e.verdict,
        Verdict::Undecided {
            probe: Probe::StrictMax
        }
    );
    // the number of equilibria on a level: 2 below c1, 4 above
    let opts = Options::default();
    assert_eq!(
        stability::analyse_level(&sys, 1.5, &opts)
            .unwrap()
            .equilibria
            .len(),
        2
    );
    assert_eq!(
        stability::analyse_level(&sys, 3.0, &opts)
            .unwrap()
            .equilibria
            .len(),
        4
    );
}

#[test]
fn type_i_sweep_locates_the_change_of_stability_at_c1() {
    let c1 = 2.0;
    let (_, sys) = model("so3_type_i", &[("c1", c1)]);
    let s = stability::sweep(&sys, 0.1, 5.0, 50, &Options::default()).unwrap();
    // the branch through (0, 0, +ρ): stable up to ρ = c1, unstable beyond
    let north = s
        .branches
        .iter()
        .find(|b| b.segments[0].p_from[2] > 0.0 && b.segments[0].p_from[0].abs() < 1e-9)
        .expect("the branch (0, 0, ρ)");
    // (ρ = c1 = 2 is a grid level: the degenerate point itself shows as a segment of width
    // ~10⁻⁶ between the two bisected boundaries, with its probe's verdict)
    let segs = &north.segments;
    assert!(segs.len() == 2 || segs.len() == 3, "{north:?}");
    assert_eq!(segs[0].class, VerdictClass::Stable);
    assert_eq!(segs[segs.len() - 1].class, VerdictClass::LinearlyUnstable);
    assert!(segs[0].refined[1] && segs[segs.len() - 1].refined[0]);
    assert!((segs[0].rho_to - c1).abs() < 1e-6, "{north:?}");
    assert!(
        (segs[segs.len() - 1].rho_from - c1).abs() < 1e-6,
        "{north:?}"
    );
    if segs.len() == 3 {
        assert_eq!(
            segs[1].verdict,
            Verdict::Undecided {
                probe: Probe::StrictMax
            }
        );
    }
    // (0, 0, −ρ) stable throughout; the two branches (±√(ρ² − c1²), 0, c1) stable where they exist
    let mut stable_throughout = 0;
    for b in &s.branches {
        if b.segments.len() == 1 && b.segments[0].class == VerdictClass::Stable {
            stable_throughout += 1;
            let g = &b.segments[0];
            if g.p_from[2] > 0.0 {
                close("P3 on the (M, 0, c1) branch", g.p_to[2], c1);
                assert!(g.rho_from > c1 && g.rho_from < c1 + 0.2, "{g:?}");
            }
        }
    }
    assert_eq!(stable_throughout, 3, "{:?}", s.branches);
}

// ---- Type IIa (§5.6) --------------------------------------------------------------------------

#[test]
fn type_iia_theorems_5_6_1_to_5_6_3() {
    for (c1, c2) in [(1.0, 4.0), (4.0, 1.0), (2.0, 3.0)] {
        let (_, sys) = model("so3_type_iia", &[("c1", c1), ("c2", c2)]);
        for m in [-1.5, 2.0] {
            // 5.6.1: (M, 0, 0) stable if c1 < c2; decided here: unstable if c1 > c2
            let e1 = at(&sys, [m, 0.0, 0.0]);
            // 5.6.2: (0, M, 0) stable if c1 > c2; decided here: unstable if c1 < c2
            let e2 = at(&sys, [0.0, m, 0.0]);
            // the rate ρ √((1/c2 − 1/c1)/c1) of the unstable one (from −ρ² det δ²)
            let rate = m.abs() * ((1.0 / c1 - 1.0 / c2).abs() * (1.0 / c1.max(c2))).sqrt();
            if c1 < c2 {
                assert!(stable(&e1), "c = ({c1}, {c2}), M = {m}: {e1:?}");
                close("rate", unstable_rate(&e2), rate);
            } else {
                assert!(stable(&e2), "c = ({c1}, {c2}), M = {m}: {e2:?}");
                close("rate", unstable_rate(&e1), rate);
            }
            // 5.6.3: (0, 0, M) stable (a minimum, H = 0 there)
            let e3 = at(&sys, [0.0, 0.0, m]);
            assert_eq!(
                e3.verdict,
                Verdict::Stable {
                    extremum: Extremum::Min
                }
            );
            close("λ", e3.lambda, 0.0);
        }
    }
}

#[test]
fn type_iia_equal_costs_give_a_circle_of_equilibria() {
    // c1 = c2 (Prop. 5.3.1): every (a, b, 0) is an equilibrium; H on the leaf is a function of
    // P3 alone with a max at P3 = 0: the circle is stable as a set, its points are not
    let (_, sys) = model("so3_type_iia", &[("c1", 2.0), ("c2", 2.0)]);
    let level = stability::analyse_level(&sys, 1.5, &Options::default()).unwrap();
    assert_eq!(level.equilibria.len(), 3, "{level:?}");
    let fam: Vec<_> = level
        .equilibria
        .iter()
        .filter(|e| e.family.is_some())
        .collect();
    assert_eq!(fam.len(), 1);
    let f = fam[0].family.as_ref().unwrap();
    assert!(
        f.closed && f.normal[2] > 1.0 - 1e-9 && f.offset.abs() < 1e-9,
        "{f:?}"
    );
    assert_eq!(
        fam[0].verdict,
        Verdict::Undecided {
            probe: Probe::FamilyStableAsSet
        }
    );
    assert!(stable(&at(&sys, [0.0, 0.0, 1.5])));
    assert!(stable(&at(&sys, [0.0, 0.0, -1.5])));
}

// ---- Type IIb (§6.6) --------------------------------------------------------------------------

#[test]
fn type_iib_theorems_6_6_1_to_6_6_3() {
    for (c1, c2) in [(1.0, 2.0), (2.0, 1.0), (1.0, 0.5)] {
        let (_, sys) = model("so3_type_iib", &[("c1", c1), ("c2", c2)]);
        let (ci, cj) = (c1.min(c2), c1.max(c2));
        for m in [-2.0, 0.7, 3.0] {
            // 6.6.1: (M, 0, c1) stable if c1 < c2; decided: unstable if c1 > c2
            let e1 = at(&sys, [m, 0.0, c1]);
            // 6.6.2: (0, M, c2) stable if c1 > c2; decided: unstable if c1 < c2
            let e2 = at(&sys, [0.0, m, c2]);
            if c1 < c2 {
                assert!(stable(&e1), "c = ({c1}, {c2}), M = {m}: {e1:?}");
                unstable_rate(&e2);
            } else {
                assert!(stable(&e2), "c = ({c1}, {c2}), M = {m}: {e2:?}");
                unstable_rate(&e1);
            }
        }
        // 6.6.3: (0, 0, M) stable for M < 0, 0 < M < ci, M > cj; decided: unstable for
        // ci < M < cj, with eigenvalues ±√((1 − M/c2)(M/c1 − 1))
        for m in [-3.0, -0.2, 0.3 * ci, 0.9 * ci, 1.1 * cj, 4.0 * cj] {
            assert!(
                stable(&at(&sys, [0.0, 0.0, m])),
                "c = ({c1}, {c2}), M = {m}"
            );
        }
        for m in [1.05 * ci, 0.5 * (ci + cj), 0.95 * cj] {
            let e = at(&sys, [0.0, 0.0, m]);
            close(
                "rate",
                unstable_rate(&e),
                ((1.0 - m / c2) * (m / c1 - 1.0)).sqrt(),
            );
        }
        // decided: M = ci is a strict max of H on the leaf (stable); M = cj is not an
        // extremum (unstable, algebraically: the linearisation is nilpotent)
        assert_eq!(
            at(&sys, [0.0, 0.0, ci]).verdict,
            Verdict::Undecided {
                probe: Probe::StrictMax
            }
        );
        assert_eq!(
            at(&sys, [0.0, 0.0, cj]).verdict,
            Verdict::Undecided {
                probe: Probe::NotExtremum
            }
        );
    }
}

#[test]
fn type_iib_equal_costs_give_a_circle_at_p3_equal_c() {
    let c = 1.5;
    let (_, sys) = model("so3_type_iib", &[("c1", c), ("c2", c)]);
    let level = stability::analyse_level(&sys, 2.5, &Options::default()).unwrap();
    let fam: Vec<_> = level
        .equilibria
        .iter()
        .filter(|e| e.family.is_some())
        .collect();
    assert_eq!(fam.len(), 1, "{level:?}");
    let f = fam[0].family.as_ref().unwrap();
    assert!(
        f.normal[2] > 1.0 - 1e-9 && (f.offset - c).abs() < 1e-8,
        "{f:?}"
    );
    assert_eq!(
        fam[0].verdict,
        Verdict::Undecided {
            probe: Probe::FamilyStableAsSet
        }
    );
    // (0, 0, ±ρ): M = −2.5 < 0 and M = 2.5 > c both stable (6.6.3 with ci = cj)
    assert_eq!(level.equilibria.len(), 3);
    assert!(stable(&at(&sys, [0.0, 0.0, 2.5])));
    assert!(stable(&at(&sys, [0.0, 0.0, -2.5])));
}

// ---- Type III (§7.6) --------------------------------------------------------------------------

#[test]
fn type_iii_theorems_7_6_1_to_7_6_3_all_orderings() {
    let orders = [
        [3.0, 2.0, 1.0],
        [3.0, 1.0, 2.0],
        [2.0, 3.0, 1.0],
        [1.0, 3.0, 2.0],
        [2.0, 1.0, 3.0],
        [1.0, 2.0, 3.0],
        [3.0, 2.0, 4.0],
    ];
    for c in orders {
        let (_, sys) = model("so3_type_iii", &[("c1", c[0]), ("c2", c[1]), ("c3", c[2])]);
        for m in [1.0, -2.5] {
            for k in 0..3 {
                let mut p = [0.0; 3];
                p[k] = m;
                let e = at(&sys, p);
                let (a, b) = (c[(k + 1) % 3], c[(k + 2) % 3]);
                let major_or_minor = (c[k] > a && c[k] > b) || (c[k] < a && c[k] < b);
                if major_or_minor {
                    assert!(stable(&e), "c = {c:?}, axis {k}: {e:?}");
                } else {
                    // the middle axis: ±|M| √((1/a − 1/c_k)(1/c_k − 1/b)) (up to order)
                    let rate = m.abs()
                        * ((1.0 / a - 1.0 / c[k]) * (1.0 / c[k] - 1.0 / b))
                            .abs()
                            .sqrt();
                    close("rate", unstable_rate(&e), rate);
                }
            }
        }
        let level = stability::analyse_level(&sys, 1.0, &Options::default()).unwrap();
        assert_eq!(level.equilibria.len(), 6);
    }
}

#[test]
fn type_iii_equal_costs() {
    // c1 = c2 ≠ c3: a circle in P3 = 0 (not covered by the thesis' conditions) and the
    // stable poles (0, 0, ±ρ)
    let (_, sys) = model("so3_type_iii", &[("c1", 2.0), ("c2", 2.0), ("c3", 1.0)]);
    let level = stability::analyse_level(&sys, 1.0, &Options::default()).unwrap();
    assert_eq!(level.equilibria.len(), 3);
    assert!(stable(&at(&sys, [0.0, 0.0, 1.0])));
    let fam = level
        .equilibria
        .iter()
        .find(|e| e.family.is_some())
        .unwrap();
    assert_eq!(
        fam.verdict,
        Verdict::Undecided {
            probe: Probe::FamilyStableAsSet
        }
    );
    // c1 = c2 = c3: the field vanishes on every level
    let (_, sys) = model("so3_type_iii", &[("c1", 2.0), ("c2", 2.0), ("c3", 2.0)]);
    assert!(
        stability::analyse_level(&sys, 1.0, &Options::default())
            .unwrap()
            .all_equilibria
    );
}

// ---- errors -----------------------------------------------------------------------------------

#[test]
fn non_lie_poisson_models_are_refused_with_what_is_supported() {
    for stem in ["kepler", "rigid_body", "cr3bp"] {
        let text = MODEL_FILES.iter().find(|(s, _)| *s == stem).unwrap().1;
        let m = LoadedModel::from_source(stem, text, Backend::Interpreter).unwrap();
        let err = stability::system(&m).unwrap_err().to_string();
        assert!(
            err.contains("`stability` analyses Lie–Poisson models (structure lie_poisson_so3)"),
            "{stem}: {err}"
        );
    }
    let (_, sys) = model("so3_type_iii", &[]);
    let err = stability::analyse_point(&sys, [1.0, 1.0, 0.0], &Options::default()).unwrap_err();
    assert!(err.to_string().contains("not an equilibrium"), "{err}");
}

// ---- dynamics ---------------------------------------------------------------------------------

const DP: [f64; 3] = [0.6e-4, -0.5e-4, 0.62e-4];

fn excursion(m: &LoadedModel, sys: &LiePoissonSystem, p: [f64; 3], scale: f64, t_end: f64) -> f64 {
    stability::max_excursion(m, sys.p_indices(), p, DP.map(|x| x * scale), t_end).unwrap()
}

#[test]
fn dynamics_stay_near_stable_and_leave_unstable_equilibria() {
    type Case = (&'static str, &'static [(&'static str, f64)], [f64; 3]);
    let cases: [Case; 14] = [
        ("so3_type_i", &[("c1", 2.0)], [1.0, 0.0, 2.0]),
        ("so3_type_i", &[("c1", 2.0)], [0.0, 0.0, 1.0]),
        ("so3_type_i", &[("c1", 2.0)], [0.0, 0.0, -1.0]),
        ("so3_type_i", &[("c1", 2.0)], [0.0, 0.0, 3.0]),
        ("so3_type_iia", &[("c1", 1.0), ("c2", 4.0)], [2.0, 0.0, 0.0]),
        ("so3_type_iia", &[("c1", 1.0), ("c2", 4.0)], [0.0, 2.0, 0.0]),
        ("so3_type_iia", &[("c1", 1.0), ("c2", 4.0)], [0.0, 0.0, 2.0]),
        ("so3_type_iib", &[("c1", 1.0), ("c2", 2.0)], [1.0, 0.0, 1.0]),
        ("so3_type_iib", &[("c1", 1.0), ("c2", 2.0)], [0.0, 1.0, 2.0]),
        ("so3_type_iib", &[("c1", 1.0), ("c2", 2.0)], [0.0, 0.0, 1.5]),
        ("so3_type_iib", &[("c1", 1.0), ("c2", 2.0)], [0.0, 0.0, 3.0]),
        (
            "so3_type_iii",
            &[("c1", 3.0), ("c2", 2.0), ("c3", 1.0)],
            [1.0, 0.0, 0.0],
        ),
        (
            "so3_type_iii",
            &[("c1", 3.0), ("c2", 2.0), ("c3", 1.0)],
            [0.0, 1.0, 0.0],
        ),
        (
            "so3_type_iii",
            &[("c1", 3.0), ("c2", 2.0), ("c3", 1.0)],
            [0.0, 0.0, 1.0],
        ),
    ];
    for (stem, params, p) in cases {
        let (m, sys) = model(stem, params);
        let e = stability::analyse_point(&sys, p, &Options::default()).unwrap();
        let d = excursion(&m, &sys, p, 1.0, 200.0);
        eprintln!(
            "{stem} {params:?} at {p:?}: {}, excursion {d:.3e}",
            e.verdict
        );
        match e.verdict.class() {
            VerdictClass::Stable => assert!(
                d < 1e-2,
                "{stem} {params:?} at {p:?}: stable, yet left to {d}"
            ),
            VerdictClass::LinearlyUnstable => {
                assert!(
                    d > 0.1,
                    "{stem} {params:?} at {p:?}: unstable, yet stayed within {d}"
                )
            }
            VerdictClass::Undecided => panic!("{stem} at {p:?}: undecided"),
        }
    }
}

#[test]
fn dynamics_decide_the_degenerate_cases() {
    // Type I at (0, 0, c1) and Type IIb at (0, 0, ci): strict max of H on the leaf → stays
    // near (the quartic well lets a 10⁻⁴ kick wander ~√(2 c1 10⁻⁴) ≈ 0.02, still near)
    let (m, sys) = model("so3_type_i", &[("c1", 2.0)]);
    let d = excursion(&m, &sys, [0.0, 0.0, 2.0], 1.0, 200.0);
    assert!(d < 5e-2, "Type I at (0, 0, c1): {d}");
    let d = excursion(&m, &sys, [0.0, 0.0, 2.0], 1.0, 2000.0);
    assert!(d < 5e-2, "Type I at (0, 0, c1), t ≤ 2000: {d}");
    let (m, sys) = model("so3_type_iib", &[("c1", 1.0), ("c2", 2.0)]);
    let d = excursion(&m, &sys, [0.0, 0.0, 1.0], 1.0, 2000.0);
    assert!(d < 5e-2, "Type IIb at (0, 0, ci): {d}");
    // Type IIb at (0, 0, cj): not an extremum; the escape is algebraic (x' ~ x²), so a 10⁻²
    // kick and a longer time
    let d = excursion(&m, &sys, [0.0, 0.0, 2.0], 100.0, 2000.0);
    assert!(d > 0.1, "Type IIb at (0, 0, cj): stayed within {d}");
}
