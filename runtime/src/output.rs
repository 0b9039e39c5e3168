//! Writing recorded runs as CSV.
//!
//! Column names come from the model's layout ([`ModelInfo::STATE`]): a scalar `E` is `E`, a
//! vector `v` gives `v[0]`, `v[1]`, …, a matrix `R` gives `R[i,j]` in column-major order
//! (the order of the flat state). Invariant errors are named `|Δname|`.

use std::io::{self, Write};

use num_traits::Float;

use crate::field::{Invariants, Shape, Slot};
use crate::observe::Recorder;

/// The component names of a list of slots, in flat order (column-major for matrices).
pub fn component_names(slots: &[Slot]) -> Vec<String> {
    let mut names = Vec::new();
    for s in slots {
        match s.shape {
            Shape::Scalar => names.push(s.name.to_string()),
            Shape::Vector(n) => names.extend((0..n).map(|i| format!("{}[{i}]", s.name))),
            Shape::Matrix(r, c) => {
                for j in 0..c {
                    for i in 0..r {
                        names.push(format!("{}[{i},{j}]", s.name));
                    }
                }
            }
        }
    }
    names
}

/// Writes a [`Recorder`]'s samples as CSV: `t`, the state components named after `state`
/// (pass `Mdl::STATE`; `x[i]` is used for components it does not cover) and one `|Δname|`
/// column per recorded invariant block. Numbers use Rust's shortest round-trip formatting.
pub fn write_csv<W, Mdl, T, const N: usize, const M: usize>(
    mut w: W,
    rec: &Recorder<'_, Mdl, T, N, M>,
    state: &[Slot],
) -> io::Result<()>
where
    W: Write,
    Mdl: Invariants<T, N, M> + ?Sized,
    T: Float + std::fmt::Display,
{
    let mut names = component_names(state);
    names.truncate(N);
    while names.len() < N {
        names.push(format!("x[{}]", names.len()));
    }
    write!(w, "t")?;
    for n in &names {
        write!(w, ",{n}")?;
    }
    for (name, _) in rec.blocks() {
        write!(w, ",|Δ{name}|")?;
    }
    writeln!(w)?;
    for i in 0..rec.len() {
        write!(w, "{}", rec.t[i])?;
        for v in &rec.x[i] {
            write!(w, ",{v}")?;
        }
        for e in rec.errors_at(i) {
            write!(w, ",{e}")?;
        }
        writeln!(w)?;
    }
    Ok(())
}
