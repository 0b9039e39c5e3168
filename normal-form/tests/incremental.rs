//! The normal forms of successive orders from one normalisation ([`normalize_model_orders`])
//! against each order computed from scratch ([`normalize_model`]): the same H̄, generating
//! function and remainder, and the same map to the normal coordinates up to rounding, with
//! the same error estimates and precision switches.

mod common;

use lasalle_normal_form::validate::EARTH_MOON_MU;
use lasalle_normal_form::{
    normalize_model, normalize_model_orders, ErrorEstimate, ModelPoint, NormalForm, Options,
    Precision,
};

fn options(precision: Precision) -> Options {
    Options {
        error_estimate: ErrorEstimate::Rotation,
        auto_precision: true,
        inverse_transform: false,
        ..Options::default()
    }
    .precision(precision)
}

fn scratch(o: &Options, n: usize, m: usize) -> NormalForm {
    let o = Options {
        order: n,
        remainder_degree: Some(m),
        ..o.clone()
    };
    let params = [("mu".to_string(), EARTH_MOON_MU)];
    normalize_model(
        common::cr3bp_model(),
        &params,
        &ModelPoint::Named("L4".into()),
        &o,
    )
    .expect("normal form")
}

fn incremental(o: &Options, orders: &[(usize, usize)]) -> Vec<NormalForm> {
    let params = [("mu".to_string(), EARTH_MOON_MU)];
    let mut out = Vec::new();
    normalize_model_orders(
        common::cr3bp_model(),
        &params,
        &ModelPoint::Named("L4".into()),
        o,
        orders,
        &mut |nf| {
            out.push(nf);
            true
        },
    )
    .expect("normal forms");
    out
}

/// Compares two normal forms of the same order: H̄, the generating function and the
/// remainder to `rel` of the largest coefficient of their degree (0: bitwise), the map to
/// the normal coordinates to `map_rel`.
fn compare(a: &NormalForm, b: &NormalForm, rel: f64, map_rel: f64) {
    assert_eq!((a.order, a.precision), (b.order, b.precision));
    let close = |x: f64, y: f64, scale: f64, tol: f64, what: &str| {
        assert!(
            (x - y).abs() <= tol * scale,
            "order {}: {what}: {x:e} vs {y:e} (scale {scale:e})",
            a.order
        );
    };
    assert_eq!(a.hamiltonian.len(), b.hamiltonian.len());
    for (x, y) in a.hamiltonian.iter().zip(&b.hamiltonian) {
        assert_eq!(x.exponents, y.exponents);
        let scale = b
            .hamiltonian
            .iter()
            .filter(|t| t.degree == y.degree)
            .map(|t| t.coeff.value.abs())
            .fold(0.0, f64::max);
        close(x.coeff.value, y.coeff.value, scale, rel, "H̄");
        close(
            x.coeff.error.unwrap_or(0.0),
            y.coeff.error.unwrap_or(0.0),
            scale,
            rel.max(1e-3 * f64::EPSILON),
            "error estimate",
        );
    }
    assert_eq!(a.generating_function.len(), b.generating_function.len());
    for (x, y) in a.generating_function.iter().zip(&b.generating_function) {
        assert_eq!(x.exponents, y.exponents);
        let scale = b
            .generating_function
            .iter()
            .filter(|t| t.degree == y.degree)
            .map(|t| t.coeff.value.abs())
            .fold(0.0, f64::max);
        close(x.coeff.value, y.coeff.value, scale, rel, "G");
    }
    let (ra, rb) = (a.remainder.as_ref().unwrap(), b.remainder.as_ref().unwrap());
    assert_eq!(ra.degree, rb.degree);
    assert_eq!(ra.parts.len(), rb.parts.len());
    for (x, y) in ra.parts.iter().zip(&rb.parts) {
        assert_eq!((x.degree, x.terms), (y.degree, y.terms));
        close(x.sum_abs, y.sum_abs, y.sum_abs, rel, "remainder");
        close(x.radial, y.radial, y.radial, rel, "remainder (radial)");
    }
    let (ma, mb) = (
        a.to_normal_map.as_ref().unwrap(),
        b.to_normal_map.as_ref().unwrap(),
    );
    for (pa, pb) in ma.components.iter().zip(&mb.components) {
        assert_eq!(pa.stored_degree(), pb.stored_degree());
        for k in 0..=pb.stored_degree() {
            let (xa, xb) = (pa.part(k).unwrap_or(&[]), pb.part(k).unwrap_or(&[]));
            let scale = xb.iter().map(|c| c.abs()).fold(0.0, f64::max);
            for (x, y) in xa.iter().zip(xb) {
                close(*x, *y, scale, map_rel, "map to the normal coordinates");
            }
        }
    }
}

#[test]
fn double_double_orders_equal_their_runs_from_scratch() {
    let o = options(Precision::DoubleDouble);
    let orders = [(6, 12), (8, 16), (12, 20), (16, 24)];
    let forms = incremental(&o, &orders);
    assert_eq!(forms.len(), orders.len());
    for (nf, &(n, m)) in forms.iter().zip(&orders) {
        // the same arithmetic: H̄, G and the remainder bitwise; the map summed differently
        compare(nf, &scratch(&o, n, m), 0.0, 1e-14);
    }
}

#[test]
fn f64_orders_switch_to_double_double_where_their_runs_do() {
    // Earth–Moon: f64 holds through order 16 and is redone in double-double at 18
    let o = options(Precision::F64);
    let orders = [(8, 16), (12, 20), (16, 24), (18, 26), (20, 28)];
    let forms = incremental(&o, &orders);
    assert_eq!(forms.len(), orders.len());
    let precisions: Vec<Precision> = forms.iter().map(|f| f.precision).collect();
    use Precision::{DoubleDouble as Dd, F64};
    assert_eq!(precisions, [F64, F64, F64, Dd, Dd]);
    for (nf, &(n, m)) in forms.iter().zip(&orders) {
        // the search carries the precision forward: later orders start where it switched
        let start = if nf.precision == Dd && n > 18 {
            Dd
        } else {
            F64
        };
        let reference = scratch(&o.clone().precision(start), n, m);
        // f64 below order 12 compensates more brackets than its run from scratch (degree
        // ≤ 12 rather than ≤ N): equal to the rounding of f64 there
        let rel = if nf.precision == F64 && n < 12 {
            1e-9
        } else {
            0.0
        };
        compare(nf, &reference, rel, 1e-12);
        assert_eq!(
            nf.diagnostics.precision_note.is_some(),
            reference.diagnostics.precision_note.is_some()
        );
    }
}
