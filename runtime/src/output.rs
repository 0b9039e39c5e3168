//! Writing recorded runs as CSV.
//!
//! Column names come from the model's layout ([`ModelInfo::state_slots`](crate::ModelInfo::state_slots)): a scalar `E` is `E`, a
//! vector `v` gives `v[0]`, `v[1]`, …, a matrix `R` gives `R[i,j]` in column-major order
//! (the order of the flat state). Invariant errors are named `|Δname|`.

use std::io::{self, Write};

use num_traits::Float;

use crate::field::{Invariants, Shape, Slot};
use crate::observe::Recorder;
use crate::state::State;

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
/// (pass `model.state_slots()`; `x[i]` is used for components it does not cover) and one `|Δname|`
/// column per recorded invariant block. Numbers use Rust's shortest round-trip formatting.
pub fn write_csv<W, Mdl, T, X, F>(
    mut w: W,
    rec: &Recorder<'_, Mdl, T, X, F>,
    state: &[Slot],
) -> io::Result<()>
where
    W: Write,
    Mdl: Invariants<T, X, F> + ?Sized,
    T: Float + std::fmt::Display,
    X: State<T>,
    F: State<T>,
{
    let n = rec.x.first().map_or(0, |x| x.len());
    let mut names = component_names(state);
    names.truncate(n);
    while names.len() < n {
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
        for v in rec.x[i].as_ref() {
            write!(w, ",{v}")?;
        }
        for e in rec.errors_at(i) {
            write!(w, ",{e}")?;
        }
        writeln!(w)?;
    }
    Ok(())
}
