//! The variational equations as emitted Rust (`lasalle_codegen::generate_extended`, the
//! modules `*_variational*` that `build.rs` generates) compute what the JIT and the
//! interpreter compute for the same extension (`lasalle_run::chaos::extend`, as
//! `lasalle run --variational` runs it), bit for bit, at random states; their x part is the
//! plain model's field to rounding, and their Φ part is DX·Φ, held against central
//! differences of the plain model's emitted field.

use lasalle::models;
use lasalle_exec::{Backend, LoadedModel};
use lasalle_run::chaos::{extend, Extension};
use lasalle_runtime::Field;

mod common;
use lasalle_testkit::{same, Rng};

/// The emitted extended field `emitted` against every back end's field of the model file
/// extended with `tangents` tangent vectors, at 200 random extended states.
fn agrees(file: &str, tangents: usize, emitted: &dyn Fn(&[f64], &mut [f64])) {
    let path = format!("{}/models/{file}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap();
    for &backend in Backend::available() {
        let base = LoadedModel::from_source(&path, &text, backend).unwrap();
        let n = base.dim();
        let ext = extend(&base, Extension::Variational { tangents }).unwrap();
        let dim = n * (1 + tangents);
        assert_eq!(ext.dim(), dim);
        let mut rng = Rng::new(0x9e37_79b9_7f4a_7c15);
        for _ in 0..200 {
            let x: Vec<f64> = (0..dim).map(|_| rng.signed(0.5, 1.5)).collect();
            let (mut jit, mut ours) = (vec![0.0; dim], vec![0.0; dim]);
            ext.field(&x, &mut jit);
            emitted(&x, &mut ours);
            for (k, (&a, &b)) in jit.iter().zip(&ours).enumerate() {
                assert!(
                    same(a, b),
                    "{file}, {tangents} tangents, component {k} at {x:?}: {backend:?} {a:e}, \
                     emitted {b:e}"
                );
            }
        }
    }
}

/// With Φ = I, Φ̇ = DX: each column against central differences of the plain emitted field
/// `plain` (relative error below 1e-7), at 20 random states.
fn jacobian_by_differences(
    n: usize,
    plain: &dyn Fn(&[f64], &mut [f64]),
    emitted: &dyn Fn(&[f64], &mut [f64]),
) {
    let mut rng = Rng::new(0x9e37_79b9_7f4a_7c15);
    for _ in 0..20 {
        let x0: Vec<f64> = (0..n).map(|_| rng.signed(0.5, 1.5)).collect();
        let x = Extension::Variational { tangents: n }.extend_state(&x0);
        let mut rates = vec![0.0; n * (1 + n)];
        emitted(&x, &mut rates);
        let mut base = vec![0.0; n];
        plain(&x0, &mut base);
        // the x part is X (to rounding: the emitted code shares subexpressions with DX)
        for (a, b) in rates[..n].iter().zip(&base) {
            assert!((a - b).abs() <= 1e-14 * b.abs().max(1.0), "X: {a} vs {b}");
        }
        for j in 0..n {
            let h = 1e-6 * x0[j].abs().max(1.0);
            let (mut up, mut down) = (x0.clone(), x0.clone());
            up[j] += h;
            down[j] -= h;
            let (mut fu, mut fd) = (vec![0.0; n], vec![0.0; n]);
            plain(&up, &mut fu);
            plain(&down, &mut fd);
            let scale = fu.iter().chain(&fd).fold(1.0_f64, |m, v| m.max(v.abs()));
            for i in 0..n {
                let fd_ij = (fu[i] - fd[i]) / (2.0 * h);
                let dx_ij = rates[n * (1 + j) + i];
                assert!(
                    (fd_ij - dx_ij).abs() <= 1e-7 * scale,
                    "DX[{i}][{j}] at {x0:?}: {dx_ij:e} emitted, {fd_ij:e} by differences"
                );
            }
        }
    }
}

#[test]
fn kepler_state_transition_matrix() {
    let sys = models::kepler_variational::KeplerVariational::<f64>::default().prepare();
    let plain = models::kepler::Kepler::<f64>::default().prepare();
    agrees("kepler.lsl", 6, &|x, dx| {
        sys.field(x.try_into().unwrap(), dx.try_into().unwrap())
    });
    jacobian_by_differences(
        6,
        &|x, dx| plain.field(x.try_into().unwrap(), dx.try_into().unwrap()),
        &|x, dx| sys.field(x.try_into().unwrap(), dx.try_into().unwrap()),
    );
    // The point starts Φ at the identity, as `lasalle run --variational` does.
    let base = models::kepler::Kepler::<f64>::default()
        .prepare()
        .point_paper();
    let want = Extension::Variational { tangents: 6 }.extend_state(&base);
    lasalle_testkit::assert_same(&sys.point_paper(), &want, "the extended point");
}

#[test]
fn henon_heiles_state_transition_matrix_and_two_tangents() {
    let stm = models::henon_heiles_variational::HenonHeilesVariational::<f64>::default().prepare();
    let two =
        models::henon_heiles_variational_2::HenonHeilesVariational2::<f64>::default().prepare();
    let plain = models::henon_heiles::HenonHeiles::<f64>::default().prepare();
    agrees("henon_heiles.lsl", 4, &|x, dx| {
        stm.field(x.try_into().unwrap(), dx.try_into().unwrap())
    });
    agrees("henon_heiles.lsl", 2, &|x, dx| {
        two.field(x.try_into().unwrap(), dx.try_into().unwrap())
    });
    jacobian_by_differences(
        4,
        &|x, dx| plain.field(x.try_into().unwrap(), dx.try_into().unwrap()),
        &|x, dx| stm.field(x.try_into().unwrap(), dx.try_into().unwrap()),
    );
    let base = plain.point_chaotic();
    let want = Extension::Variational { tangents: 2 }.extend_state(&base);
    lasalle_testkit::assert_same(&two.point_chaotic(), &want, "the extended point");
}

#[test]
fn rigid_body_three_tangents() {
    let sys = models::rigid_body_variational_3::RigidBodyVariational3::<f64>::default().prepare();
    agrees("rigid_body.lsl", 3, &|x, dx| {
        sys.field(x.try_into().unwrap(), dx.try_into().unwrap())
    });
}
