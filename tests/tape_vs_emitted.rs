//! The tapes of `lasalle_codegen::tape`, their back ends and the loaded models compute what the
//! emitted Rust computes, bitwise: every function (X, f, Df, V, ∇V, X − ∇V and, where the field
//! is partitioned, the half-fields) of every model in `models/`, at random states.
//!
//! The models are the ones `build.rs` generates from the directory (its `for_each_model!`), so
//! a model file added there is checked here without a line of this file changing;
//! `every_model_file_is_checked` holds that list against the directory. A model emitted in
//! its loop form (a family of at least `AUTO_MIN_TUPLES` index tuples) is checked against the
//! loaded model's loop kernels, which it equals, rather than against the unrolled tapes.

use lasalle::models;
use lasalle_codegen::tape::{ModelTapes, Tape};
use lasalle_exec::{Backend, Families, Kernel, LoadedModel};
use lasalle_runtime::{Declared, Lyapunov, State};

mod common;
use common::tapes;
use lasalle_testkit::{assert_within_ulps, known_ulps};

include!(concat!(env!("OUT_DIR"), "/model_list.rs"));

/// A tape with its kernel on every back end and their hoisted values.
struct Compiled<'a> {
    what: &'static str,
    /// The ulps the emitted values may differ by (`lasalle_testkit::known_ulps`).
    ulps: u64,
    tape: &'a Tape,
    kernels: Vec<(Backend, Box<dyn Kernel>, Vec<f64>)>,
}

impl<'a> Compiled<'a> {
    fn new(what: &'static str, tape: &'a Tape, params: &[f64]) -> Self {
        let kernels = Backend::available()
            .iter()
            .map(|&b| {
                let k = b.compile(tape).unwrap();
                let h = k.hoist(params).unwrap();
                (b, k, h)
            })
            .collect();
        Compiled {
            what,
            ulps: 0,
            tape,
            kernels,
        }
    }

    /// The tape (`Tape::eval`) and every back end against the emitted values.
    fn agree(&self, params: &[f64], x: &[f64], t: &[f64], g: &[f64], emitted: &[f64]) {
        let tape = self.tape;
        let (t, g) = (&t[..tape.dims.targets], &g[..tape.dims.gains]);
        let mut results = vec![("tape".to_string(), tape.eval(params, x, t, g).unwrap())];
        for (backend, k, h) in &self.kernels {
            let mut out = vec![0.0; k.n_outputs()];
            k.eval(h, x, t, g, &mut out).unwrap();
            results.push((format!("{backend:?}"), out));
        }
        for (name, got) in results {
            assert_within_ulps(
                &got,
                emitted,
                self.ulps,
                format!("{} at x = {x:?}: {name} vs emitted", self.what),
            );
        }
    }
}

/// Numbers in ±[0.5, 1.5), from a fixed seed.
fn rng() -> impl FnMut() -> f64 {
    let mut rng = lasalle_testkit::Rng::new(0x9e37_79b9_7f4a_7c15);
    move || (0.5 + rng.unit()) * rng.sign()
}

/// Every function of a model at `x`, by name, in the layout of the tapes' outputs (Df by rows;
/// the half-fields as their q and p components only, in the order of the state).
fn functions<P, X, F, K>(m: &P, x: &X, target: &F, gains: &K) -> Vec<(&'static str, Vec<f64>)>
where
    P: Lyapunov<f64, X, F, K> + Declared<f64, X>,
    X: State<f64>,
    F: State<f64>,
    K: State<f64>,
{
    let mut dx = x.clone();
    m.field(x, &mut dx);
    let mut f = target.clone();
    m.invariants(x, &mut f);
    let mut jac = F::rows(target.as_ref().len(), x.clone());
    m.invariants_jacobian(x, &mut jac);
    let jac: Vec<f64> = jac
        .as_ref()
        .iter()
        .flat_map(|r| r.as_ref().to_vec())
        .collect();
    let (mut grad, mut fb) = (x.clone(), x.clone());
    m.lyapunov_gradient(x, target, gains, &mut grad);
    m.feedback_field(x, target, gains, &mut fb);
    let mut out = vec![
        ("field", dx.as_ref().to_vec()),
        ("invariants", f.as_ref().to_vec()),
        ("jacobian", jac),
        ("lyapunov", vec![m.lyapunov(x, target, gains)]),
        ("lyapunov_gradient", grad.as_ref().to_vec()),
        ("feedback", fb.as_ref().to_vec()),
    ];
    if let Some(p) = m.partitioned() {
        let (mut dq, mut dp) = (x.clone(), x.clone());
        p.field_q(x, &mut dq);
        p.field_p(x, &mut dp);
        let is_q = p.is_q();
        let pick = |v: &X, q: bool| -> Vec<f64> {
            let v = v.as_ref();
            (0..v.len())
                .filter(|&k| is_q[k] == q)
                .map(|k| v[k])
                .collect()
        };
        out.push(("field_q", pick(&dq, true)));
        out.push(("field_p", pick(&dp, false)));
    }
    out
}

/// The emitted model `sys` of `file` against its tapes on every back end (unless `loops`: the
/// loop form equals the loop kernels, not the unrolled tapes) and against the model loaded
/// from its file on every back end, as `build.rs` loads it (`Families::Auto`), at 200 random
/// states, the targets those of a random state and the model's default gains.
fn check<P, const N: usize, const M: usize, const G: usize>(
    file: &str,
    sys: &P,
    targets: impl Fn(&[f64; N]) -> [f64; M],
    gains: [f64; G],
    loops: bool,
) where
    P: Lyapunov<f64, [f64; N], [f64; M], [f64; G]> + Declared<f64, [f64; N]>,
{
    let (model, tapes) = tapes(file);
    let params = model.default_params();
    let p = &params[..];
    let ModelTapes {
        field,
        invariants,
        jacobian,
        lyapunov,
        lyapunov_gradient,
        feedback,
        partition,
        ..
    } = &tapes;
    let is_q = sys.partitioned().map(|s| s.is_q().to_vec());
    assert_eq!(
        is_q,
        partition.as_ref().map(|part| part.is_q.clone()),
        "{file}: the emitted partition and the tapes'"
    );
    let mut compiled = vec![];
    if !loops {
        compiled = [
            ("field", field),
            ("invariants", invariants),
            ("jacobian", jacobian),
            ("lyapunov", lyapunov),
            ("lyapunov_gradient", lyapunov_gradient),
            ("feedback", feedback),
        ]
        .map(|(what, tape)| Compiled::new(what, tape, p))
        .into_iter()
        .collect();
        if let Some(part) = partition {
            compiled.push(Compiled::new("field_q", &part.field_q, p));
            compiled.push(Compiled::new("field_p", &part.field_p, p));
        }
        for c in &mut compiled {
            c.ulps = known_ulps(file);
        }
    }
    let path = format!("{}/models/{file}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap();
    let loaded: Vec<(Backend, LoadedModel)> = Backend::available()
        .iter()
        .map(|&b| {
            let m = LoadedModel::from_source_with(file, &text, b, Families::Auto)
                .unwrap_or_else(|e| panic!("{file}: {e}"));
            (b, m)
        })
        .collect();
    let mut rand = rng();
    let target = targets(&std::array::from_fn(|_| rand()));
    for _ in 0..200 {
        let x: [f64; N] = std::array::from_fn(|_| rand());
        let emitted = functions(sys, &x, &target, &gains);
        assert_eq!(emitted.len(), 6 + 2 * usize::from(is_q.is_some()));
        for (c, (what, values)) in compiled.iter().zip(&emitted) {
            assert_eq!(c.what, *what);
            c.agree(p, &x, &target, &gains, values);
        }
        for (backend, m) in &loaded {
            let theirs = functions(m, &x.to_vec(), &target.to_vec(), &gains.to_vec());
            assert_eq!(theirs.len(), emitted.len(), "{file}: {backend:?} loaded");
            for ((what, a), (_, b)) in emitted.iter().zip(&theirs) {
                assert_within_ulps(
                    b,
                    a,
                    known_ulps(file),
                    format!("{file}: {what} at {x:?}: {backend:?} loaded vs emitted"),
                );
            }
        }
    }
}

macro_rules! check_model {
    ($module:ident, $ty:ident, $prepared:ident, $file:literal, loops: $loops:tt, $($flags:tt)*) => {
        #[test]
        fn $module() {
            use models::$module::$ty as Model;
            let sys = Model::default().prepare();
            check(
                $file,
                &sys,
                |x| sys.targets(x),
                Model::default_gains(),
                $loops,
            );
        }
    };
}

for_each_model!(check_model);

/// The models checked above are every model file of `models/`.
#[test]
fn every_model_file_is_checked() {
    let mut checked = Vec::new();
    macro_rules! name {
        ($module:ident, $ty:ident, $prepared:ident, $file:literal, $($rest:tt)*) => {
            checked.push($file.to_string());
        };
    }
    for_each_model!(name);
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/models");
    let mut files: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "lsl"))
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    files.sort();
    assert_eq!(checked, files);
}
