//! Initial states and numbers from text, as a model file's user writes them: a named point
//! (`paper`) or the flat state as comma-separated numbers, and lists of values
//! (`start:stop:count` or comma-separated) for output times and parameter grids.

use std::fmt;

use lasalle_runtime::{ModelInfo, Parameters};

use crate::RunError;

/// Why a list of values ([`parse_values`]) does not parse.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum ValuesError {
    /// A value that is not a finite number (the text as given, trimmed).
    NotANumber(String),
    /// The count of `start:stop:count` is not a whole number ≥ 1 (the text as given, trimmed).
    Count(String),
    /// `start:stop:1` with start ≠ stop: one value cannot lie at both ends.
    OneValue {
        /// The range's first value.
        start: f64,
        /// The range's last value.
        stop: f64,
    },
    /// Neither `start:stop:count` nor a comma-separated list (one colon, or more than two).
    Shape,
}

impl fmt::Display for ValuesError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ValuesError::NotANumber(s) => write!(f, "`{s}` is not a finite number"),
            ValuesError::Count(s) => write!(f, "`{s}` is not a count ≥ 1"),
            ValuesError::OneValue { start, stop } => write!(
                f,
                "one value from {start} to {stop}: give start = stop, or the value alone"
            ),
            ValuesError::Shape => f.write_str(
                "write `start:stop:count` (count values from start to stop) or a comma-separated list",
            ),
        }
    }
}

impl std::error::Error for ValuesError {}

/// Values as text: `start:stop:count`, count evenly spaced values from start to stop with both
/// ends exact (`0:1:5` is 0, 0.25, 0.5, 0.75, 1; `2:2:1` is 2), or comma-separated finite
/// numbers (`0.5, 2, 3`). Output times and parameter grids are written this way.
pub fn parse_values(text: &str) -> Result<Vec<f64>, ValuesError> {
    let number = |s: &str| {
        let s = s.trim();
        s.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| ValuesError::NotANumber(s.to_string()))
    };
    match text.split(':').collect::<Vec<_>>().as_slice() {
        [start, stop, count] => {
            let (start, stop) = (number(start)?, number(stop)?);
            let count = count.trim();
            let n: usize = count
                .parse()
                .ok()
                .filter(|&n| n >= 1)
                .ok_or_else(|| ValuesError::Count(count.to_string()))?;
            if n == 1 {
                return if start == stop {
                    Ok(vec![start])
                } else {
                    Err(ValuesError::OneValue { start, stop })
                };
            }
            Ok((0..n)
                .map(|i| {
                    if i == n - 1 {
                        stop
                    } else {
                        start + (stop - start) * i as f64 / (n - 1) as f64
                    }
                })
                .collect())
        }
        [list] => list.split(',').map(number).collect(),
        _ => Err(ValuesError::Shape),
    }
}

/// Comma-separated finite numbers.
pub fn parse_numbers(text: &str) -> Result<Vec<f64>, String> {
    text.split(',')
        .map(|s| {
            let s = s.trim();
            match s.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => Err(format!("`{s}` is not a finite number")),
            }
        })
        .collect()
}

/// The initial state `init`: a named point of the model (evaluated with its current
/// parameters) or N comma-separated numbers in the flat state order. The wrong count is an
/// error that shows the state's layout.
pub fn initial_state<M>(model: &M, init: &str) -> Result<Vec<f64>, RunError>
where
    M: Parameters + ModelInfo + ?Sized,
{
    let n = model.state_dim();
    let looks_numeric = |t: &str| {
        t.contains(',')
            || t.starts_with(|c: char| c.is_ascii_digit() || "+-.".contains(c))
            || t.parse::<f64>().is_ok()
    };
    let values = if let Some(p) = model.point(init.trim()) {
        p
    } else if looks_numeric(init.trim()) {
        parse_numbers(init).map_err(|e| RunError::Model(format!("invalid --init: {e}")))?
    } else {
        return Err(RunError::Model(format!(
            "unknown point `{init}`; model has points: {} (or give {n} comma-separated numbers)",
            model.point_names().join(", ")
        )));
    };
    if values.len() != n {
        let layout: Vec<String> = model
            .state_slots()
            .iter()
            .map(|s| {
                format!(
                    "{}: {} at [{}..{}]",
                    s.name,
                    s.shape,
                    s.offset,
                    s.offset + s.shape.len()
                )
            })
            .collect();
        return Err(RunError::Model(format!(
            "--init has {} numbers but the state of `{}` has dimension {n} ({})",
            values.len(),
            model.model_name(),
            layout.join(", ")
        )));
    }
    Ok(values)
}

#[cfg(test)]
mod tests {
    use super::{parse_values, ValuesError};

    #[test]
    fn ranges_and_lists() {
        assert_eq!(parse_values("0:1:5").unwrap(), [0.0, 0.25, 0.5, 0.75, 1.0]);
        assert_eq!(parse_values("0.5, 2,3").unwrap(), [0.5, 2.0, 3.0]);
        assert_eq!(parse_values("2:2:1").unwrap(), [2.0]);
        assert_eq!(parse_values("-1").unwrap(), [-1.0]);
        // the last value is `stop` itself, not start + (stop − start)·(n − 1)/(n − 1)
        let v = parse_values("0.1:0.7:7").unwrap();
        assert_eq!(v.len(), 7);
        assert_eq!(v[6].to_bits(), 0.7f64.to_bits());
    }

    #[test]
    fn each_mistake_has_its_error() {
        let cases = [
            ("a:1:3", ValuesError::NotANumber("a".into())),
            ("1,,2", ValuesError::NotANumber("".into())),
            ("nan", ValuesError::NotANumber("nan".into())),
            ("0: inf :3", ValuesError::NotANumber("inf".into())),
            ("0:1:0", ValuesError::Count("0".into())),
            ("0:1:2.5", ValuesError::Count("2.5".into())),
            (
                "0:1:1",
                ValuesError::OneValue {
                    start: 0.0,
                    stop: 1.0,
                },
            ),
            ("0:1", ValuesError::Shape),
            ("0:1:2:3", ValuesError::Shape),
        ];
        for (text, want) in cases {
            assert_eq!(parse_values(text), Err(want), "{text}");
        }
    }
}
