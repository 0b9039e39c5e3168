//! The driver: equilibrium → Taylor expansion → linear normalisation → Lie normalisation →
//! [`NormalForm`], in either precision, with an error estimate from the other precision.

mod assemble;
mod errors;
mod expansion;
mod options;
mod result;
mod stages;

pub use options::{
    ErrorEstimate, Options, Point, Precision, Progress, Stage, DEFAULT_MAX_RELATIVE_ERROR,
    MAX_ORDER,
};
pub use result::{
    ActionTerm, ArnoldMoser, DegreeError, Diagnostics, NormalForm, PolyMap, Remainder,
    RemainderPart, ResonantTerm, SmallDivisor, Term, Timings, Value,
};

use crate::error::NormalFormError;
use crate::hamiltonian::HamiltonianFn;

use crate::{Dd, Qd};
use assemble::assemble;
use errors::{
    attach_errors, estimate_errors, fill_degree_errors, inaccurate_degree, precision_lost,
    prune_generating,
};
pub(crate) use expansion::{integer_vectors, minus_i_pow};
use options::validate_options;
use stages::{run, run_orders};

fn run_assembled<H: HamiltonianFn + ?Sized>(
    h: &H,
    point: &Point,
    o: &Options,
) -> Result<NormalForm, NormalFormError> {
    match o.precision {
        Precision::F64 => run::<f64, H>(h, point, o).map(|r| assemble(h, r, o)),
        Precision::DoubleDouble => run::<Dd, H>(h, point, o).map(|r| assemble(h, r, o)),
        Precision::QuadDouble => run::<Qd, H>(h, point, o).map(|r| assemble(h, r, o)),
    }
}

/// [`run_orders`] in the precision of `o`, each result assembled with its order and
/// remainder degree.
fn run_orders_assembled<H: HamiltonianFn + ?Sized>(
    h: &H,
    point: &Point,
    o: &Options,
    orders: &[(usize, usize)],
    emit: &mut dyn FnMut(NormalForm) -> bool,
) -> Result<(), NormalFormError> {
    let at = |n: usize| Options {
        order: n,
        remainder_degree: orders.iter().find(|x| x.0 == n).map(|x| x.1),
        ..o.clone()
    };
    match o.precision {
        Precision::F64 => run_orders::<f64, H>(h, point, o, orders, &mut |raw, n| {
            emit(assemble(h, raw, &at(n)))
        }),
        Precision::DoubleDouble => run_orders::<Dd, H>(h, point, o, orders, &mut |raw, n| {
            emit(assemble(h, raw, &at(n)))
        }),
        Precision::QuadDouble => run_orders::<Qd, H>(h, point, o, orders, &mut |raw, n| {
            emit(assemble(h, raw, &at(n)))
        }),
    }
}

/// The normal forms of several orders N with their remainder degrees M, `orders` =
/// [(N, M), …] with N increasing, from one normalisation: the generating functions and the
/// transformed terms of the lower degrees are those of every higher order, so each order
/// costs only its new degrees (the table reaches the largest M from the start; see
/// `lie::Normalizer`). Each result is what [`normalize`] gives with `order` N and
/// `remainder_degree` M (`options.order` and `options.remainder_degree` are ignored):
/// the same coefficients (bitwise in double-double and quad-double), the same error
/// estimate and precision check; an order that fails the check with `auto_precision`
/// continues the normalisation in the wider precision from that order on. Each result goes
/// to `on_form` as soon as it is complete; it returns whether to go on.
pub fn normalize_orders<H: HamiltonianFn + ?Sized>(
    h: &H,
    point: &Point,
    options: &Options,
    orders: &[(usize, usize)],
    on_form: &mut dyn FnMut(NormalForm) -> bool,
) -> Result<(), NormalFormError> {
    for (k, &(n, m)) in orders.iter().enumerate() {
        validate_options(&Options {
            order: n,
            remainder_degree: Some(m),
            ..options.clone()
        })?;
        if m < n || (k > 0 && orders[k - 1].0 >= n) {
            return Err(NormalFormError::Invalid(format!(
                "orders must increase with remainder degrees M ≥ N, got (N, M) = ({n}, {m})"
            )));
        }
    }
    let mut precision = options.precision;
    let mut next = 0usize;
    let mut carried: Option<(NormalForm, f64)> = None;
    let mut notes: Vec<String> = Vec::new();
    let mut note_order = 0usize;
    while next < orders.len() {
        let o = Options {
            precision,
            ..options.clone()
        };
        let (mut failed, mut stop, mut widen) = (None, false, None);
        let rest = &orders[next..];
        let mut emit = |mut nf: NormalForm| -> bool {
            let o_n = Options {
                order: nf.order,
                remainder_degree: orders.get(next).map(|x| x.1),
                ..o.clone()
            };
            match carried.take() {
                Some((narrow, spent)) => {
                    // the narrower run is the other-precision estimate of this one, as in
                    // `normalize`
                    let factor = nf.precision.epsilon() / narrow.precision.epsilon();
                    attach_errors(&mut nf, &narrow, factor, true, narrow.precision.epsilon());
                    nf.diagnostics.error_method = Some(format!(
                        "|{} - {}| * 2^{}",
                        narrow.precision,
                        nf.precision,
                        factor.log2().round()
                    ));
                    let _ = spent;
                    nf.diagnostics.precision_note = Some(notes.join("; "));
                    fill_degree_errors(&mut nf);
                }
                None => estimate_errors(&mut nf, h, point, &o_n),
            }
            if let Some((degree, err)) = options
                .max_relative_error
                .and_then(|limit| inaccurate_degree(&nf, limit))
            {
                let limit = options.max_relative_error.unwrap_or(0.0);
                match nf.precision.wider() {
                    Some(w) if options.auto_precision => widen = Some((nf, w, degree, err)),
                    _ => failed = Some(precision_lost(nf.precision, degree, err, limit)),
                }
                return false;
            }
            prune_generating(&mut nf);
            next += 1;
            if !on_form(nf) {
                stop = true;
                return false;
            }
            true
        };
        run_orders_assembled(h, point, &o, rest, &mut emit)?;
        if let Some(e) = failed {
            return Err(e);
        }
        match widen {
            Some((narrow, wider, degree, err)) if !stop => {
                Progress::report(&options.progress, Stage::Rerun(wider));
                if note_order != narrow.order {
                    notes.clear();
                    note_order = narrow.order;
                }
                let spent =
                    narrow.diagnostics.timings.total + narrow.diagnostics.timings.error_estimate;
                notes.push(format!(
                    "{} is not enough here: a coefficient of degree {degree} of Hbar had an \
                     estimated relative error of {err:.1e} in {} (limit {:.0e}), so the \
                     normal form was recomputed in {} ({spent:.3} s spent before)",
                    narrow.precision,
                    narrow.precision,
                    options.max_relative_error.unwrap_or(0.0),
                    match wider {
                        Precision::DoubleDouble => "double-double",
                        _ => "quad-double",
                    }
                ));
                precision = wider;
                carried = Some((narrow, spent));
            }
            _ => break,
        }
    }
    Ok(())
}

/// Computes the Birkhoff normal form of `h` at the equilibrium found from `point`.
///
/// Steps: Newton on ∇H = 0 (in the working precision) → Taylor expansion of H to degree N
/// by jet arithmetic → symplectic diagonalisation of H₂ (fails with
/// [`NormalFormError::NotElliptic`]) → Assumption 1′ check (fails with
/// [`NormalFormError::Resonance`] unless `resonant`) → Lie-series normalisation → real
/// forms of H̄, the generators and the transformation. With `error_estimate` the other
/// precision is run too (without the transformation) and each coefficient gets
/// `error = |c_f64 − c_dd|` (f64 run) or `|c_f64 − c_dd|·2⁻⁵¹` (double-double run: the same
/// amplification of rounding errors acting on a unit roundoff 2⁵¹ times smaller).
pub fn normalize<H: HamiltonianFn + ?Sized>(
    h: &H,
    point: &Point,
    options: &Options,
) -> Result<NormalForm, NormalFormError> {
    validate_options(options)?;
    let mut nf = run_assembled(h, point, options)?;
    estimate_errors(&mut nf, h, point, options);
    if let Some(limit) = options.max_relative_error {
        let mut notes: Vec<String> = Vec::new();
        let mut spent = 0.0;
        while let Some((degree, err)) = inaccurate_degree(&nf, limit) {
            let wider = match nf.precision.wider() {
                Some(w) if options.auto_precision => w,
                _ => return Err(precision_lost(nf.precision, degree, err, limit)),
            };
            Progress::report(&options.progress, Stage::Rerun(wider));
            let narrow = nf.precision;
            spent += nf.diagnostics.timings.total + nf.diagnostics.timings.error_estimate;
            let wide_opts = Options {
                precision: wider,
                ..options.clone()
            };
            let narrow_nf = nf;
            nf = run_assembled(h, point, &wide_opts)?;
            // the narrower run is the other-precision estimate of the wider one, for free:
            // the same amplification acting on a smaller unit roundoff
            let factor = wider.epsilon() / narrow.epsilon();
            attach_errors(&mut nf, &narrow_nf, factor, true, narrow.epsilon());
            nf.diagnostics.error_method = Some(format!(
                "|{narrow} - {wider}| * 2^{}",
                factor.log2().round()
            ));
            notes.push(format!(
                "{narrow} is not enough here: a coefficient of degree {degree} of Hbar had an \
                 estimated relative error of {err:.1e} in {narrow} (limit {limit:.0e}), so the \
                 normal form was recomputed in {} ({spent:.3} s spent before)",
                match wider {
                    Precision::DoubleDouble => "double-double",
                    _ => "quad-double",
                }
            ));
            nf.diagnostics.precision_note = Some(notes.join("; "));
            fill_degree_errors(&mut nf);
        }
    }
    prune_generating(&mut nf);
    Progress::report(&options.progress, Stage::Done);
    Ok(nf)
}
