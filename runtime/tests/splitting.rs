//! Three-rotation splitting of the free rigid body (GNI §VII.5, pp. 284–285).

#![allow(clippy::needless_range_loop)]

mod common;

use common::*;
use lasalle_runtime::*;

const INERTIA: [f64; 3] = [3.0, 2.0, 1.0];

fn generic_state() -> [f64; 12] {
    // a rotation R = exp(hat(a)) (via the splitting itself) and a generic Ω
    let s = RigidBodySplitting::new(INERTIA);
    let mut x = RigidBody::initial();
    x[9..12].copy_from_slice(&[0.3, -0.7, 1.1]);
    s.sub_flow(0, 0.4, &mut x);
    s.sub_flow(1, 0.9, &mut x);
    s.sub_flow(2, -0.5, &mut x);
    x[9..12].copy_from_slice(&[1.0, 0.5, -0.8]);
    x
}

fn h_k(x: &[f64; 12], k: usize) -> f64 {
    let m = INERTIA[k] * x[9 + k];
    m * m / (2.0 * INERTIA[k])
}

fn casimir(x: &[f64; 12]) -> f64 {
    (0..3).map(|k| (INERTIA[k] * x[9 + k]).powi(2)).sum()
}

/// Each sub-flow is the exact flow of H_k = m_k²/(2I_k): it keeps π = R𝕀Ω, |m|², H_k and
/// RᵀR = I to round-off, and its derivative at τ = 0 is the H_k part of the Euler equations.
/// The total energy H is *not* kept by a single sub-flow (only by the exact full flow).
#[test]
fn sub_flows_are_exact_rotations() {
    let body = rigid_body(INERTIA);
    let s = RigidBodySplitting::new(INERTIA);
    let x0 = generic_state();
    let pi0 = body.spatial_momentum(&x0);
    for k in 0..3 {
        let mut x = x0;
        s.sub_flow(k, 0.37, &mut x);
        assert!(
            dist(&body.spatial_momentum(&x), &pi0) < 1e-14,
            "π, axis {k}"
        );
        assert!((casimir(&x) - casimir(&x0)).abs() < 1e-14, "|m|², axis {k}");
        assert!((h_k(&x, k) - h_k(&x0, k)).abs() < 1e-15, "H_{k}");
        assert!(RigidBody::orthogonality_error(&x) < 1e-14);
        let de = body.energy(&x) - body.energy(&x0);
        assert!(de.abs() > 1e-3, "axis {k}: H unexpectedly kept ({de:e})");
        // the sub-flow derivative: ṁ = m × (m_k/I_k) e_k, Ṙ = R hat((m_k/I_k) e_k)
        let eps = 1e-6;
        let (mut xp, mut xm) = (x0, x0);
        s.sub_flow(k, eps, &mut xp);
        s.sub_flow(k, -eps, &mut xm);
        let w = [
            if k == 0 { x0[9] } else { 0.0 },
            if k == 1 { x0[10] } else { 0.0 },
            if k == 2 { x0[11] } else { 0.0 },
        ];
        let m: [f64; 3] = std::array::from_fn(|i| INERTIA[i] * x0[9 + i]);
        let mdot = cross(&m, &w);
        for i in 0..3 {
            let fd = INERTIA[i] * (xp[9 + i] - xm[9 + i]) / (2.0 * eps);
            assert!(
                (fd - mdot[i]).abs() < 1e-8,
                "axis {k}: ṁ{i} {fd} vs {}",
                mdot[i]
            );
        }
        for a in 0..3 {
            for b in 0..3 {
                // (R ŵ)_ab = Σ_c R_ac ŵ_cb, ŵ_cb = −ε_cbd w_d
                let rw: f64 = (0..3)
                    .map(|c| {
                        let what = match (c, b) {
                            (0, 1) => -w[2],
                            (0, 2) => w[1],
                            (1, 0) => w[2],
                            (1, 2) => -w[0],
                            (2, 0) => -w[1],
                            (2, 1) => w[0],
                            _ => 0.0,
                        };
                        x0[a + 3 * c] * what
                    })
                    .sum();
                let fd = (xp[a + 3 * b] - xm[a + 3 * b]) / (2.0 * eps);
                assert!((fd - rw).abs() < 1e-8, "axis {k}: Ṙ[{a},{b}]");
            }
        }
    }
}

/// The composed step keeps π and RᵀR = I to round-off over 10⁵ steps (no drift beyond
/// round-off accumulation), keeps the energy bounded (symplectic), and is time-reversible.
#[test]
fn composition_conserves_momentum_and_orthogonality() {
    let body = rigid_body(INERTIA);
    let x0 = RigidBody::initial();
    let mut s = RigidBodySplitting::new(INERTIA);
    let pi0 = body.spatial_momentum(&x0);
    let e0 = body.energy(&x0);
    let (mut worst_pi, mut worst_orth, mut worst_e) = (0.0f64, 0.0f64, 0.0f64);
    let h = 0.01;
    integrate(
        &mut s,
        &body,
        &x0,
        0.0,
        1000.0,
        h,
        &mut |_n: u64, _t: f64, x: &[f64; 12]| {
            worst_pi = worst_pi.max(dist(&body.spatial_momentum(x), &pi0));
            worst_orth = worst_orth.max(RigidBody::orthogonality_error(x));
            worst_e = worst_e.max((body.energy(x) - e0).abs());
            Control::Continue
        },
    )
    .unwrap();
    eprintln!("1e5 steps h = {h}: max |Δπ| {worst_pi:.3e}, |RᵀR − I| {worst_orth:.3e}, |ΔE| {worst_e:.3e}");
    assert!(worst_pi < 1e-11 && worst_orth < 1e-11);
    // O(h²) energy error without drift
    assert!(worst_e < 1e-3 && worst_e > 1e-8);
    // reversibility
    let mut x = generic_state();
    let x_start = x;
    Stepper::<f64, [f64; 12], RigidBody>::step(&mut s, &body, 0.0, &mut x, 0.1).unwrap();
    Stepper::<f64, [f64; 12], RigidBody>::step(&mut s, &body, 0.1, &mut x, -0.1).unwrap();
    assert!(dist(&x, &x_start) < 1e-14);
}

#[test]
fn axis_order_is_configurable() {
    let body = rigid_body(INERTIA);
    let x0 = RigidBody::initial();
    let mut a = RigidBodySplitting::new(INERTIA);
    let mut b = RigidBodySplitting::with_axes(INERTIA, [2, 1, 0]);
    let ea = integrate(&mut a, &body, &x0, 0.0, 1.0, 0.01, &mut ())
        .unwrap()
        .x;
    let eb = integrate(&mut b, &body, &x0, 0.0, 1.0, 0.01, &mut ())
        .unwrap()
        .x;
    assert!(dist(&ea, &eb) > 1e-8 && dist(&ea, &eb) < 1e-3);
}
