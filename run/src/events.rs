//! Events and output times of a run: what [`simulate`](crate::simulate) records of the model's
//! events (`event NAME: g = 0 …;`, located by [`lasalle_runtime::events`]) and how it samples
//! the output times of [`RunSpec::t_eval`](crate::RunSpec::t_eval), with their CSV and JSON.

use std::io::Write;
use std::path::Path;

use lasalle_runtime::Csv;
use serde_json::json;

use crate::recording::json_number;
use crate::{Recording, RunError};

/// One crossing of a non-terminal event, or the terminal crossing that ended a run.
#[derive(Clone, Debug, PartialEq)]
pub struct EventHit {
    /// The event's name.
    pub name: String,
    /// Its time.
    pub t: f64,
    /// The state there, [`Recording::state_names`] order.
    pub x: Vec<f64>,
    /// The invariants' values f(x) there, [`Recording::invariant_names`] order.
    pub invariants: Vec<f64>,
    /// From g < 0 to g > 0 (for a touch: from below).
    pub rising: bool,
    /// A graze: g reached zero without (resolvably) crossing it.
    pub touch: bool,
}

/// Output times as `--t-eval` takes them: `a:b:n` (n equally spaced times from a to b, both
/// included) or a comma-separated list ([`parse_values`](crate::parse_values)).
pub fn parse_t_eval(text: &str) -> Result<Vec<f64>, RunError> {
    crate::parse_values(text).map_err(|e| RunError::Spec(format!("--t-eval {text}: {e}")))
}

impl Recording {
    /// Writes the non-terminal events as CSV to the file `path` (see
    /// [`Recording::write_events_csv_to`]).
    pub fn write_events_csv(&self, path: impl AsRef<Path>) -> std::io::Result<()> {
        let path = path.as_ref();
        let file = std::fs::File::create(path).map_err(|e| {
            std::io::Error::new(e.kind(), format!("cannot create {}: {e}", path.display()))
        })?;
        self.write_events_csv_to(file)
    }

    /// Writes the non-terminal events as CSV: `event`, `t`, the state components, the
    /// invariants' components (their values f(x)); one line per crossing, in time order.
    pub fn write_events_csv_to(&self, out: impl Write) -> std::io::Result<()> {
        let mut csv = Csv::new(std::io::BufWriter::new(out));
        let header = ["event".to_string(), "t".to_string()]
            .into_iter()
            .chain(self.state_names.iter().cloned())
            .chain(self.invariant_names.iter().cloned());
        csv.record(header)?;
        for e in &self.events {
            let numbers = std::iter::once(&e.t).chain(&e.x).chain(&e.invariants);
            csv.record(std::iter::once(e.name.clone()).chain(numbers.map(f64::to_string)))?;
        }
        csv.into_inner()?;
        Ok(())
    }

    /// The events part of the summary: how many crossings of each event, and the terminal
    /// one that ended the run (`null` if none did).
    pub fn events_json(&self) -> serde_json::Value {
        let mut counts = serde_json::Map::new();
        for e in &self.events {
            let c = counts.entry(e.name.clone()).or_insert(json!(0));
            *c = json!(c.as_u64().unwrap_or(0) + 1);
        }
        json!({
            "counts": counts,
            "stopped_by": self.stopped_by.as_ref().map(|e| json!({
                "event": e.name,
                "t": json_number(e.t),
            })),
        })
    }

    /// The crossings of the event `name`.
    pub fn events_named<'a>(&'a self, name: &'a str) -> impl Iterator<Item = &'a EventHit> {
        self.events.iter().filter(move |e| e.name == name)
    }
}

#[cfg(test)]
mod tests {
    use super::parse_t_eval;

    #[test]
    fn grids_and_lists() {
        assert_eq!(parse_t_eval("0:1:5").unwrap(), [0.0, 0.25, 0.5, 0.75, 1.0]);
        assert_eq!(parse_t_eval("0.5, 2,3").unwrap(), [0.5, 2.0, 3.0]);
        assert_eq!(parse_t_eval("2:2:1").unwrap(), [2.0]);
        for bad in ["0:1", "0:1:0", "a:1:3", "1,,2", "0:1:2:3", "nan"] {
            assert!(parse_t_eval(bad).is_err(), "{bad}");
        }
    }
}
