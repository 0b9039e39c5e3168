//! Argument text shared by subcommands: `--param name=v1,v2,…`, `--grid name=start:stop:count`,
//! and names compared without case or separators.

use lasalle::run::parse_values;
use lasalle::{parse_numbers, Parameters};

pub use lasalle::run::normalise;

/// `name=v1,v2,…` as the parameter's name and its values.
pub fn parse_param(text: &str) -> Result<(String, Vec<f64>), String> {
    let (name, values) = text
        .split_once('=')
        .ok_or_else(|| format!("invalid --param `{text}`: expected `name=value[,value…]`"))?;
    let values = parse_numbers(values).map_err(|e| format!("invalid --param `{text}`: {e}"))?;
    Ok((name.trim().to_string(), values))
}

/// `--grid name=start:stop:count` or `name=v1,v2,…` as the axis's name and its values
/// ([`parse_values`]).
pub fn parse_grid_axis(text: &str) -> Result<(String, Vec<f64>), String> {
    let (name, spec) = text.split_once('=').ok_or_else(|| {
        format!("invalid --grid `{text}`: expected `name=start:stop:count` or `name=v1,v2,…`")
    })?;
    let values = parse_values(spec).map_err(|e| format!("invalid --grid `{text}`: {e}"))?;
    Ok((name.trim().to_string(), values))
}

/// Applies `name=v1,v2,…` to the model's parameters.
pub fn apply_param<P: Parameters + ?Sized>(model: &mut P, text: &str) -> Result<(), String> {
    let (name, values) = parse_param(text)?;
    model.set_param(&name, &values).map_err(|e| e.to_string())
}
