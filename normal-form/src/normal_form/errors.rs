//! The error estimate: a second run in the other precision (or with rotated normal planes),
//! the per-degree errors, the precision check and the pruning of rounding noise.

use super::options::{ErrorEstimate, Options, Point, Precision, Progress, Stage};
use super::result::{NormalForm, Value};
use super::run_assembled;
use crate::error::NormalFormError;
use crate::hamiltonian::HamiltonianFn;
use crate::scalar::Real;
use crate::Dd;
use std::time::Instant;

/// Attaches the error estimate `options.error_estimate` to `nf` (computed with `options`).
pub(super) fn estimate_errors<H: HamiltonianFn + ?Sized>(
    nf: &mut NormalForm,
    h: &H,
    point: &Point,
    options: &Options,
) {
    let t = Instant::now();
    let (other_opts, factor, method) = match options.error_estimate {
        ErrorEstimate::None => return,
        ErrorEstimate::Rotation => {
            // angles far from any symmetry of the problem
            let rotation: Vec<f64> = (0..nf.n_dof)
                .map(|k| 0.7 + 1.3 * k as f64 * if k % 2 == 0 { 1.0 } else { -1.0 })
                .collect();
            (
                Options {
                    basis_rotation: rotation,
                    ..options.clone()
                },
                1.0,
                "|c - c(normal planes rotated)|",
            )
        }
        ErrorEstimate::OtherPrecision => match options.precision {
            Precision::F64 => (
                Options {
                    precision: Precision::DoubleDouble,
                    ..options.clone()
                },
                1.0,
                "|f64 - dd|",
            ),
            Precision::DoubleDouble => (
                Options {
                    precision: Precision::F64,
                    ..options.clone()
                },
                2f64.powi(-51),
                "|f64 - dd| * 2^-51",
            ),
            Precision::QuadDouble => (
                Options {
                    precision: Precision::DoubleDouble,
                    ..options.clone()
                },
                2f64.powi(-105),
                "|dd - qd| * 2^-105",
            ),
        },
    };
    let other_opts = Options {
        error_estimate: ErrorEstimate::None,
        transform: false,
        remainder_degree: None,
        ..other_opts
    };
    Progress::report(&options.progress, Stage::Rerun(other_opts.precision));
    if let Ok(other) = run_assembled(h, point, &other_opts) {
        let narrow_unit = other.precision.epsilon().max(nf.precision.epsilon());
        attach_errors(
            nf,
            &other,
            factor,
            options.error_estimate != ErrorEstimate::Rotation,
            narrow_unit,
        );
        nf.diagnostics.error_method = Some(method.into());
        fill_degree_errors(nf);
    }
    nf.diagnostics.timings.error_estimate = t.elapsed().as_secs_f64();
}

/// Coefficients smaller than this many unit roundoffs of the largest of their degree are
/// measured against that size in [`DegreeError::max_relative_error`].
const RESOLVABLE: f64 = 1e3;

/// [`DegreeError::max_error`] and [`DegreeError::max_relative_error`] from the estimates.
pub(super) fn fill_degree_errors(nf: &mut NormalForm) {
    let unit = nf.precision.epsilon();
    for d in nf.diagnostics.hbar_degrees.iter_mut() {
        let floor = RESOLVABLE * unit * d.max_coeff;
        let (mut abs, mut rel, mut any) = (0.0f64, 0.0f64, false);
        for t in nf.hamiltonian.iter().filter(|t| t.degree == d.degree) {
            if let Some(e) = t.coeff.error {
                any = true;
                if e == 0.0 && t.coeff.value == 0.0 {
                    continue; // an exact zero
                }
                abs = abs.max(e);
                let m = t.coeff.value.abs().max(floor);
                rel = rel.max(if m > 0.0 { e / m } else { 0.0 });
            }
        }
        if any {
            d.max_error = Some(abs);
            d.max_relative_error = Some(rel);
        }
    }
}

/// The lowest degree of H̄ with an estimated relative error above `limit`, with that error.
pub(super) fn inaccurate_degree(nf: &NormalForm, limit: f64) -> Option<(usize, f64)> {
    nf.diagnostics
        .hbar_degrees
        .iter()
        .filter_map(|d| d.max_relative_error.map(|e| (d.degree, e)))
        .find(|&(_, e)| e > limit || e.is_nan())
}

pub(super) fn precision_lost(
    precision: Precision,
    degree: usize,
    err: f64,
    limit: f64,
) -> NormalFormError {
    let below = degree.saturating_sub(1);
    NormalFormError::PrecisionLost {
        precision: precision.to_string(),
        degree,
        relative_error: err,
        limit,
        advice: match precision {
            Precision::F64 => {
                format!("use `--precision dd` (or `auto`), or `--order {below}` or lower")
            }
            Precision::DoubleDouble => {
                format!("use `--precision auto` (quad-double), or `--order {below}` or lower")
            }
            Precision::QuadDouble => format!("use `--order {below}` or lower"),
        },
    }
}

/// Drops generator coefficients that are rounding noise (the real form of a complex
/// polynomial has exact zeros that come out as ~ε·max).
pub(super) fn prune_generating(nf: &mut NormalForm) {
    let eps = 2.0 * nf.precision.epsilon();
    let mut max_by_degree = vec![0.0f64; nf.order + 1];
    for t in &nf.generating_function {
        max_by_degree[t.degree] = max_by_degree[t.degree].max(t.coeff.value.abs());
    }
    nf.generating_function
        .retain(|t| t.coeff.value.abs() > 1e3 * eps * max_by_degree[t.degree]);
}

fn err(a: &Value, b: &Value, factor: f64, unit: f64) -> f64 {
    let diff = ((a.value - b.value) + (a.lo - b.lo)).abs() * factor;
    // never claim better than the working precision (`unit`: the run's own unit roundoff;
    // the reported values carry double-double digits at most)
    let floor = if factor < 1.0 {
        4.0 * unit.max(Dd::EPSILON)
    } else {
        unit
    } * a.value.abs();
    diff.max(floor)
}

/// Errors from a second run `other`: `|difference|·factor`. With `generators = false` (a run
/// with rotated normal planes) the generating function, which depends on the rotation, gets
/// none.
pub(super) fn attach_errors(
    nf: &mut NormalForm,
    other: &NormalForm,
    factor: f64,
    generators: bool,
    narrow_unit: f64,
) {
    let unit = nf.precision.epsilon();
    let err = |a: &Value, b: &Value, factor: f64| err(a, b, factor, unit);
    let pairs = |a: &mut [Value], b: &[Value]| {
        for (x, y) in a.iter_mut().zip(b) {
            x.error = Some(err(x, y, factor));
        }
    };
    pairs(&mut nf.equilibrium, &other.equilibrium);
    pairs(&mut nf.omega, &other.omega);
    nf.energy.error = Some(err(&nf.energy, &other.energy, factor));
    let mut amp: f64 = 0.0;
    for (x, y) in nf.hamiltonian.iter_mut().zip(&other.hamiltonian) {
        let e = err(&x.coeff, &y.coeff, factor);
        x.coeff.error = Some(e);
        let (f, dd) = if factor == 1.0 {
            (&x.coeff, &y.coeff)
        } else {
            (&y.coeff, &x.coeff)
        };
        if dd.value != 0.0 {
            amp = amp.max(
                ((f.value - dd.value) + (f.lo - dd.lo)).abs() / (dd.value.abs() * narrow_unit),
            );
        }
    }
    nf.diagnostics.amplification = Some(amp);
    if generators {
        for (x, y) in nf
            .generating_function
            .iter_mut()
            .zip(&other.generating_function)
        {
            x.coeff.error = Some(err(&x.coeff, &y.coeff, factor));
        }
    }
    if let (Some(a), Some(b)) = (nf.d4.as_mut(), other.d4.as_ref()) {
        a.a.error = Some(err(&a.a, &b.a, factor));
        a.b.error = Some(err(&a.b, &b.b, factor));
        a.c.error = Some(err(&a.c, &b.c, factor));
        a.d4.error = Some(err(&a.d4, &b.d4, factor));
    }
}
