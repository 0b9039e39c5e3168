//! Writing CSV: [`Csv`], the one CSV writer of the workspace (RFC 4180 quoting), and
//! [`write_csv`] for recorded runs.
//!
//! Column names come from the model's layout ([`ModelInfo::state_slots`](crate::ModelInfo::state_slots)): a scalar `E` is `E`, a
//! vector `v` gives `v[0]`, `v[1]`, …, a matrix `R` gives `R[i,j]` in column-major order
//! (the order of the flat state). Invariant errors are named `|Δname|`.

use std::fmt::{Display, Write as _};
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

/// A CSV writer (RFC 4180): one [`record`](Csv::record) per line, fields separated by commas,
/// a field quoted (`"…"`, inner quotes doubled) when it contains a comma, a quote or a line
/// break — component names such as `R[0,1]` and failure messages do. Numbers are written with
/// Rust's shortest round-trip formatting (`Display`).
#[derive(Debug)]
pub struct Csv<W: Write> {
    out: W,
    field: String,
}

impl<W: Write> Csv<W> {
    /// A writer into `out` (wrap files in a `BufWriter`).
    pub fn new(out: W) -> Self {
        Csv {
            out,
            field: String::new(),
        }
    }

    /// Writes one line.
    pub fn record<I>(&mut self, fields: I) -> io::Result<()>
    where
        I: IntoIterator,
        I::Item: Display,
    {
        for (k, value) in fields.into_iter().enumerate() {
            if k > 0 {
                self.out.write_all(b",")?;
            }
            self.field.clear();
            let _ = write!(self.field, "{value}");
            if self.field.contains([',', '"', '\n', '\r']) {
                write!(self.out, "\"{}\"", self.field.replace('"', "\"\""))?;
            } else {
                self.out.write_all(self.field.as_bytes())?;
            }
        }
        self.out.write_all(b"\n")
    }

    /// Flushes and returns the underlying writer.
    pub fn into_inner(mut self) -> io::Result<W> {
        self.out.flush()?;
        Ok(self.out)
    }
}

/// Writes a [`Recorder`]'s samples as CSV: `t`, the state components named after `state`
/// (pass `model.state_slots()`; `x[i]` is used for components it does not cover) and one `|Δname|`
/// column per recorded invariant block.
pub fn write_csv<W, Mdl, T, X, F>(
    w: W,
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
    let n = rec.dim();
    let mut names = component_names(state);
    names.truncate(n);
    while names.len() < n {
        names.push(format!("x[{}]", names.len()));
    }
    let mut csv = Csv::new(w);
    let header = std::iter::once("t".to_string())
        .chain(names)
        .chain(rec.blocks().iter().map(|(name, _)| format!("|Δ{name}|")));
    csv.record(header)?;
    for i in 0..rec.len() {
        let row = std::iter::once(&rec.t[i])
            .chain(rec.state(i))
            .chain(rec.errors_at(i));
        csv.record(row)?;
    }
    csv.into_inner().map(drop)
}

#[cfg(test)]
mod tests {
    use super::Csv;

    #[test]
    fn fields_are_quoted_when_needed() {
        let mut csv = Csv::new(Vec::new());
        csv.record(["t", "R[0,1]", "say \"hi\"", "a\nb"]).unwrap();
        csv.record([1.5, -0.0, 0.25]).unwrap();
        let text = String::from_utf8(csv.into_inner().unwrap()).unwrap();
        assert_eq!(
            text,
            "t,\"R[0,1]\",\"say \"\"hi\"\"\",\"a\nb\"\n1.5,-0,0.25\n"
        );
    }
}
