//! The generated models agree with hand transcriptions of the paper's formulas
//! (Chang, Jiménez, Perlmutter 2016): the fields (13), (31), (42); the integrals; the
//! gradients (19a,b), Lemma 3.5 and §3.3 — at 1000 random states each, to 1e-12 relative —
//! and ∇V agrees with central finite differences of V.

use lasalle::models::{kepler::Kepler, perturbed_kepler::PerturbedKepler, rigid_body::RigidBody};
use lasalle::{Field, Invariants, Lyapunov};
use lasalle_testkit::Rng;
use nalgebra::{Matrix3, Vector3};

const SAMPLES: usize = 1000;
const REL: f64 = 1e-12;

fn assert_close(what: &str, got: &[f64], want: &[f64], rel: f64) {
    let scale = want.iter().fold(0.0f64, |m, w| m.max(w.abs())).max(1e-300);
    let err = got
        .iter()
        .zip(want)
        .fold(0.0f64, |m, (g, w)| m.max((g - w).abs()));
    assert!(
        err <= rel * scale,
        "{what}: max error {err:.3e} relative {:.3e}\n got  {got:?}\n want {want:?}",
        err / scale
    );
}

/// ∇V against central differences of V (step ~1e-5, truncation error ~1e-10).
fn check_against_finite_differences<M, const N: usize, const K: usize, const G: usize>(
    m: &M,
    x: &[f64; N],
    target: &[f64; K],
    gains: &[f64; G],
) where
    M: Lyapunov<f64, [f64; N], [f64; K], [f64; G]>,
{
    let mut grad = [0.0; N];
    m.lyapunov_gradient(x, target, gains, &mut grad);
    let fd: Vec<f64> = (0..N)
        .map(|i| {
            let h = 1e-5 * x[i].abs().max(1.0);
            let (mut a, mut b) = (*x, *x);
            a[i] += h;
            b[i] -= h;
            (m.lyapunov(&a, target, gains) - m.lyapunov(&b, target, gains)) / (2.0 * h)
        })
        .collect();
    assert_close("∇V vs finite differences", &grad, &fd, 1e-6);
}

fn split<const N: usize>(x: &[f64; N], at: usize) -> (Vector3<f64>, Vector3<f64>) {
    (
        Vector3::from_column_slice(&x[at - 3..at]),
        Vector3::from_column_slice(&x[at..at + 3]),
    )
}

#[test]
fn kepler_matches_the_paper() {
    let m = Kepler::<f64>::default().prepare();
    let (k1, k2) = (4.0, 2.0);
    let mu = m.mu;
    let mut rng = Rng::new(1);
    for _ in 0..SAMPLES {
        let x0: [f64; 6] = rng.array(-1.5, 1.5);
        let x: [f64; 6] = rng.array(-1.5, 1.5);
        if Vector3::from_column_slice(&x[..3]).norm() < 0.2 {
            continue;
        }
        let (xv, v) = split(&x, 3);
        let r = xv.norm();
        // (31)
        let mut dx = [0.0; 6];
        m.field(&x, &mut dx);
        let acc = -mu * xv / r.powi(3);
        assert_close(
            "field",
            &dx,
            &[v[0], v[1], v[2], acc[0], acc[1], acc[2]],
            REL,
        );
        // (32), (33)
        let l = xv.cross(&v);
        let a = v.cross(&l) - mu * xv / r;
        let mut f = [0.0; 6];
        m.invariants(&x, &mut f);
        assert_close("L, A", &f, &[l[0], l[1], l[2], a[0], a[1], a[2]], REL);
        // Lemma 3.5
        let target = m.targets(&x0);
        let (dl, da) = (
            l - Vector3::from_column_slice(&target[..3]),
            a - Vector3::from_column_slice(&target[3..]),
        );
        let gx = k1 * v.cross(&dl)
            + k2 * (v.cross(&da.cross(&v)) - (mu / r) * da + (mu / r.powi(3)) * xv * xv.dot(&da));
        let gv = k1 * dl.cross(&xv) + k2 * (xv.cross(&v).cross(&da) + xv.cross(&v.cross(&da)));
        let mut grad = [0.0; 6];
        m.lyapunov_gradient(&x, &target, &[k1, k2], &mut grad);
        assert_close(
            "∇V (Lemma 3.5)",
            &grad,
            &[gx[0], gx[1], gx[2], gv[0], gv[1], gv[2]],
            REL,
        );
        // (41) = (31) − ∇V
        let mut fb = [0.0; 6];
        m.feedback_field(&x, &target, &[k1, k2], &mut fb);
        let want: Vec<f64> = (0..6).map(|i| dx[i] - grad[i]).collect();
        assert_close("X − ∇V", &fb, &want, REL);
        check_against_finite_differences(&m, &x, &target, &[k1, k2]);
    }
}

#[test]
fn perturbed_kepler_matches_the_paper() {
    let m = PerturbedKepler::<f64>::default().prepare();
    let (k1, k2) = (2.0, 3.0);
    let (mu, delta) = (m.mu, m.delta);
    let u = |r: f64| -mu / r - delta / r.powi(3);
    let du = |r: f64| mu / r.powi(2) + 3.0 * delta / r.powi(4);
    let mut rng = Rng::new(2);
    for _ in 0..SAMPLES {
        let x0: [f64; 6] = rng.array(-1.5, 1.5);
        let x: [f64; 6] = rng.array(-1.5, 1.5);
        if Vector3::from_column_slice(&x[..3]).norm() < 0.2 {
            continue;
        }
        let (xv, v) = split(&x, 3);
        let r = xv.norm();
        let mut dx = [0.0; 6];
        m.field(&x, &mut dx);
        let acc = -du(r) * xv / r;
        assert_close(
            "field (42)",
            &dx,
            &[v[0], v[1], v[2], acc[0], acc[1], acc[2]],
            REL,
        );
        let e = 0.5 * v.dot(&v) + u(r);
        let l = xv.cross(&v);
        let mut f = [0.0; 4];
        m.invariants(&x, &mut f);
        assert_close("E, L (43), (44)", &f, &[e, l[0], l[1], l[2]], REL);
        let target = m.targets(&x0);
        let (de, dl) = (e - target[0], l - Vector3::from_column_slice(&target[1..]));
        let gx = k1 * de * du(r) * xv / r + k2 * v.cross(&dl);
        let gv = k1 * de * v + k2 * dl.cross(&xv);
        let mut grad = [0.0; 6];
        m.lyapunov_gradient(&x, &target, &[k1, k2], &mut grad);
        assert_close(
            "∇V (§3.3)",
            &grad,
            &[gx[0], gx[1], gx[2], gv[0], gv[1], gv[2]],
            REL,
        );
        check_against_finite_differences(&m, &x, &target, &[k1, k2]);
    }
}

#[test]
fn rigid_body_matches_the_paper() {
    let m = RigidBody::<f64>::default().prepare();
    let inertia = Matrix3::from_diagonal(&Vector3::from_column_slice(&m.i));
    let (k0, k1, k2) = (50.0, 100.0, 50.0);
    let hat = |w: &Vector3<f64>| Matrix3::new(0.0, -w[2], w[1], w[2], 0.0, -w[0], -w[1], w[0], 0.0);
    let mut rng = Rng::new(3);
    for _ in 0..SAMPLES {
        let x0: [f64; 12] = rng.array(-1.5, 1.5);
        let x: [f64; 12] = rng.array(-1.5, 1.5);
        let r = Matrix3::from_column_slice(&x[..9]);
        let w = Vector3::from_column_slice(&x[9..]);
        // (13)
        let rdot = r * hat(&w);
        let wdot = inertia.try_inverse().unwrap() * (inertia * w).cross(&w);
        let mut dx = [0.0; 12];
        m.field(&x, &mut dx);
        let want: Vec<f64> = rdot.iter().chain(wdot.iter()).copied().collect();
        assert_close("field (13)", &dx, &want, REL);
        // RᵀR − I, E, π
        let c = r.transpose() * r - Matrix3::identity();
        let e = 0.5 * w.dot(&(inertia * w));
        let pi = r * inertia * w;
        let mut f = [0.0; 13];
        m.invariants(&x, &mut f);
        let want: Vec<f64> = c
            .iter()
            .copied()
            .chain([e])
            .chain(pi.iter().copied())
            .collect();
        assert_close("RᵀR − I, E, π", &f, &want, REL);
        // (19a), (19b)
        let target = m.targets(&x0);
        let (de, dpi) = (
            e - target[9],
            pi - Vector3::from_column_slice(&target[10..]),
        );
        let gr = k0 * r * c + k2 * dpi * (inertia * w).transpose();
        let gw = k1 * de * inertia * w + k2 * inertia * r.transpose() * dpi;
        let mut grad = [0.0; 12];
        m.lyapunov_gradient(&x, &target, &[k0, k1, k2], &mut grad);
        let want: Vec<f64> = gr.iter().chain(gw.iter()).copied().collect();
        assert_close("∇V (19a,b)", &grad, &want, REL);
        // (18) itself
        let v = k0 / 4.0 * c.norm_squared() + k1 / 2.0 * de * de + k2 / 2.0 * dpi.norm_squared();
        let got = m.lyapunov(&x, &target, &[k0, k1, k2]);
        assert!(
            (got - v).abs() <= REL * v.abs().max(1e-300),
            "V (18): {got} vs {v}"
        );
        check_against_finite_differences(&m, &x, &target, &[k0, k1, k2]);
    }
}

#[test]
fn paper_initial_conditions() {
    // §4.1: E(0) = 3, π(0) = (3, 2, 1)
    let rb = RigidBody::<f64>::default().prepare();
    let f = rb.targets(&rb.point_paper());
    assert_close("rigid body E0, π0", &f[9..], &[3.0, 3.0, 2.0, 1.0], 1e-15);
    // §4.2: L(0) = (0, 0, √1.8), A(0) = (0.8, 0, 0)
    let k = Kepler::<f64>::default().prepare();
    let f = k.targets(&k.point_paper());
    assert_close(
        "Kepler L0, A0",
        &f,
        &[0.0, 0.0, 1.8f64.sqrt(), 0.8, 0.0, 0.0],
        1e-15,
    );
    // §4.3: E(0) = −0.5390625, L(0) = (0, 0, 0.8)
    let p = PerturbedKepler::<f64>::default().prepare();
    let f = p.targets(&p.point_paper());
    assert_close(
        "perturbed Kepler E0, L0",
        &f,
        &[-0.5390625, 0.0, 0.0, 0.8],
        1e-15,
    );
}

#[test]
fn generated_code_is_generic_over_the_scalar() {
    let m64 = RigidBody::<f64>::default().prepare();
    let m32 = RigidBody::<f32>::default().prepare();
    let x = m64.point_paper();
    let x32 = x.map(|v| v as f32 * 1.01);
    let x64 = x32.map(f64::from);
    let target = m64.targets(&x);
    let (mut a, mut b) = ([0.0f64; 12], [0.0f32; 12]);
    m64.feedback_field(&x64, &target, &[50.0, 100.0, 50.0], &mut a);
    m32.feedback_field(
        &x32,
        &target.map(|v| v as f32),
        &[50.0, 100.0, 50.0],
        &mut b,
    );
    let b: Vec<f64> = b.iter().map(|&v| f64::from(v)).collect();
    assert_close("f32 vs f64", &b, &a, 1e-5);
}
