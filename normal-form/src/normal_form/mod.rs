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
use stages::run;

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
