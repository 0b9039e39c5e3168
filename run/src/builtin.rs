//! The repository's model files (`models/*.lsl`), embedded so that every front end (the
//! command line, the Python package) finds them by name from any directory, and the lookup of
//! a model given as a path or as the name of one of them.

use std::fmt;
use std::path::Path;

include!(concat!(env!("OUT_DIR"), "/model_files.rs"));

/// Lower case without `-` and `_`, so `rigid-body`, `rigid_body` and `RigidBody` agree: how
/// names given by a user (models, methods, back ends) are compared.
pub fn normalise(s: &str) -> String {
    s.chars()
        .filter(|c| *c != '-' && *c != '_')
        .flat_map(char::to_lowercase)
        .collect()
}

/// The names of the built-in models (the stems of [`MODEL_FILES`]), sorted.
pub fn builtin_models() -> Vec<&'static str> {
    MODEL_FILES.iter().map(|(stem, _)| *stem).collect()
}

/// A model file's text, with where it came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ModelText {
    /// The path to show in messages: the path as given, or `models/<stem>.lsl` for a built-in
    /// model.
    pub path: String,
    /// The file stem, the name for output directories.
    pub stem: String,
    /// The model file's text.
    pub text: String,
}

/// Why [`model_text`] found no model.
#[derive(Debug)]
#[non_exhaustive]
pub enum LookupError {
    /// A path that could not be read.
    Unreadable {
        /// The path as given.
        path: String,
        /// Why it could not be read.
        source: std::io::Error,
    },
    /// Neither a path nor the name of a built-in model.
    Unknown {
        /// The name as given.
        name: String,
    },
}

impl fmt::Display for LookupError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LookupError::Unreadable { path, source } => {
                write!(f, "cannot read model file `{path}`: {source}")
            }
            LookupError::Unknown { name } => write!(
                f,
                "no model `{name}`: give a path to a model file (`my_model.lsl`) or one of the \
                 built-in models: {}",
                builtin_models().join(", ")
            ),
        }
    }
}

impl std::error::Error for LookupError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            LookupError::Unreadable { source, .. } => Some(source),
            LookupError::Unknown { .. } => None,
        }
    }
}

/// The model `arg`: a path to a model file (it ends in `.lsl`, contains a path separator, or
/// names an existing file) or the name of a built-in model, compared as [`normalise`] does
/// (`rigid-body` is `models/rigid_body.lsl`).
pub fn model_text(arg: &str) -> Result<ModelText, LookupError> {
    let path = Path::new(arg);
    if arg.ends_with(".lsl") || arg.contains(['/', '\\']) || path.is_file() {
        let text = std::fs::read_to_string(path).map_err(|source| LookupError::Unreadable {
            path: arg.to_string(),
            source,
        })?;
        let stem = path
            .file_stem()
            .map_or_else(|| arg.to_string(), |s| s.to_string_lossy().into_owned());
        return Ok(ModelText {
            path: arg.to_string(),
            stem,
            text,
        });
    }
    let key = normalise(arg);
    MODEL_FILES
        .iter()
        .find(|(stem, _)| normalise(stem) == key)
        .map(|(stem, text)| ModelText {
            path: format!("models/{stem}.lsl"),
            stem: stem.to_string(),
            text: text.to_string(),
        })
        .ok_or_else(|| LookupError::Unknown {
            name: arg.to_string(),
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_model_file_is_embedded_under_its_stem() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../models");
        let mut on_disk: Vec<(String, String)> = std::fs::read_dir(dir)
            .expect("the models/ folder")
            .map(|e| e.expect("an entry").path())
            .filter(|p| p.extension().is_some_and(|x| x == "lsl"))
            .map(|p| {
                let stem = p.file_stem().unwrap().to_string_lossy().into_owned();
                (stem, std::fs::read_to_string(&p).unwrap())
            })
            .collect();
        on_disk.sort();
        let embedded: Vec<(String, String)> = MODEL_FILES
            .iter()
            .map(|(s, t)| (s.to_string(), t.to_string()))
            .collect();
        assert!(embedded.len() >= 6, "{} models", embedded.len());
        assert_eq!(embedded, on_disk);
    }

    #[test]
    fn names_match_without_case_or_separators() {
        for name in ["rigid_body", "rigid-body", "RigidBody", "RIGID_BODY"] {
            let found = model_text(name).expect(name);
            assert_eq!(found.path, "models/rigid_body.lsl");
            assert_eq!(found.stem, "rigid_body");
            assert!(found.text.contains("model RigidBody"), "{name}");
        }
    }

    #[test]
    fn paths_are_read_and_misses_are_typed() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../models/kepler.lsl");
        let found = model_text(path).unwrap();
        assert_eq!((found.path.as_str(), found.stem.as_str()), (path, "kepler"));
        match model_text("no/such/model.lsl") {
            Err(e @ LookupError::Unreadable { .. }) => {
                assert!(e
                    .to_string()
                    .starts_with("cannot read model file `no/such/model.lsl`: "))
            }
            other => panic!("{other:?}"),
        }
        match model_text("keplr") {
            Err(e @ LookupError::Unknown { .. }) => {
                let m = e.to_string();
                assert!(m.starts_with("no model `keplr`: give a path"), "{m}");
                assert!(m.contains("kepler, "), "{m}");
            }
            other => panic!("{other:?}"),
        }
    }
}
