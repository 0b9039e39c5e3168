//! Initial states and numbers from text, as a model file's user writes them: a named point
//! (`paper`) or the flat state as comma-separated numbers.

use lasalle_runtime::{ModelInfo, Parameters};

use crate::RunError;

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
