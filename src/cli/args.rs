//! Argument text shared by subcommands: `--param name=v1,v2,…`, and names compared without
//! case or separators.

use lasalle::{parse_numbers, Parameters};

/// Lower case without `-` and `_`, so `rigid-body`, `rigid_body` and `RigidBody` agree.
pub fn normalise(s: &str) -> String {
    s.chars()
        .filter(|c| *c != '-' && *c != '_')
        .flat_map(char::to_lowercase)
        .collect()
}

/// `name=v1,v2,…` as the parameter's name and its values.
pub fn parse_param(text: &str) -> Result<(String, Vec<f64>), String> {
    let (name, values) = text
        .split_once('=')
        .ok_or_else(|| format!("invalid --param `{text}`: expected `name=value[,value…]`"))?;
    let values = parse_numbers(values).map_err(|e| format!("invalid --param `{text}`: {e}"))?;
    Ok((name.trim().to_string(), values))
}

/// Applies `name=v1,v2,…` to the model's parameters.
pub fn apply_param<P: Parameters + ?Sized>(model: &mut P, text: &str) -> Result<(), String> {
    let (name, values) = parse_param(text)?;
    model.set_param(&name, &values).map_err(|e| e.to_string())
}
