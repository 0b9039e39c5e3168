//! Rust identifiers for model names: snake_case-ish, unique within a scope, never a keyword.

use std::collections::{HashMap, HashSet};

const RUST_KEYWORDS: &[&str] = &[
    "as", "async", "await", "break", "const", "continue", "crate", "dyn", "else", "enum", "extern",
    "false", "fn", "for", "if", "impl", "in", "let", "loop", "match", "mod", "move", "mut", "pub",
    "ref", "return", "self", "Self", "static", "struct", "super", "trait", "true", "type",
    "unsafe", "use", "where", "while", "abstract", "become", "box", "do", "final", "macro",
    "override", "priv", "typeof", "unsized", "virtual", "yield", "try", "gen",
];

/// Names the generated module uses at its top level (imports, the number type `T`, the
/// prelude and primitive types it writes): a model's struct may not be called so, or it would
/// shadow them.
const EMITTED_NAMES: &[&str] = &[
    "T",
    "Float",
    "One",
    "Zero",
    "lit",
    "nalgebra",
    "MatrixView",
    "MatrixViewMut",
    "Scalar",
    "GuardFailure",
    "EventDirection",
    "EventSpec",
    "Declared",
    "Preset",
    "Splitting",
    "Field",
    "InvariantInfo",
    "InvariantKind",
    "Invariants",
    "Lyapunov",
    "ModelInfo",
    "ParamError",
    "Parameters",
    "Partitioned",
    "Shape",
    "Slot",
    "core",
    "std",
    "lasalle_runtime",
    "Option",
    "Some",
    "None",
    "Result",
    "Ok",
    "Err",
    "Vec",
    "String",
    "ToString",
    "Default",
    "Deref",
    "Clone",
    "Copy",
    "Debug",
    "PartialEq",
    "Sized",
    "Send",
    "Sync",
    "f32",
    "f64",
    "i8",
    "i16",
    "i32",
    "i64",
    "i128",
    "isize",
    "u8",
    "u16",
    "u32",
    "u64",
    "u128",
    "usize",
    "bool",
    "char",
    "str",
];

/// Is `name` one of nalgebra's dimension types `U1`, `U2`, … (the state views use them)?
pub fn is_dimension(name: &str) -> bool {
    name.strip_prefix('U')
        .is_some_and(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
}

/// Why `name` cannot be the Rust type of a model, if it cannot: a keyword, `_`, or a name the
/// generated code itself uses.
pub fn reserved_type_name(name: &str) -> Option<String> {
    if RUST_KEYWORDS.contains(&name) || name.chars().all(|c| c == '_') {
        Some(format!("`{name}` is a Rust keyword"))
    } else if EMITTED_NAMES.contains(&name) || is_dimension(name) {
        Some(format!("the generated code uses the name `{name}` itself"))
    } else {
        None
    }
}

/// The snake_case form of a model name: `Omega → omega`, `dU → d_u`, `RigidBody → rigid_body`.
pub fn snake(name: &str) -> String {
    let mut out = String::new();
    let chars: Vec<char> = name.chars().collect();
    for (i, &c) in chars.iter().enumerate() {
        if c.is_ascii_uppercase() {
            let prev_lower =
                i > 0 && (chars[i - 1].is_ascii_lowercase() || chars[i - 1].is_ascii_digit());
            let next_lower = chars.get(i + 1).is_some_and(|n| n.is_ascii_lowercase());
            let prev_upper = i > 0 && chars[i - 1].is_ascii_uppercase();
            if prev_lower || (prev_upper && next_lower) {
                out.push('_');
            }
            out.push(c.to_ascii_lowercase());
        } else {
            out.push(c);
        }
    }
    out
}

/// `base` made a valid identifier: a leading letter, and a `_` after a keyword (`type_`).
pub fn identifier(base: &str) -> String {
    let mut base = base.to_string();
    // `_` alone is a pattern, not a name; a leading digit starts no identifier.
    if base.chars().all(|c| c == '_') || base.starts_with(|c: char| c.is_ascii_digit()) {
        base.insert(0, 'v');
    }
    if RUST_KEYWORDS.contains(&base.as_str()) {
        base.push('_');
    }
    base
}

/// The identifiers taken in one scope.
#[derive(Default)]
pub struct Scope {
    taken: HashSet<String>,
    /// For each base, the suffix to try first: every smaller one is taken (so naming n
    /// temporaries after one base costs O(n), not O(n²)).
    next: HashMap<String, usize>,
}

impl Scope {
    /// A scope where `reserved` are already taken (function arguments, `self`).
    pub fn with(reserved: &[&str]) -> Self {
        Scope {
            taken: reserved.iter().map(|s| s.to_string()).collect(),
            next: HashMap::new(),
        }
    }

    /// Marks `name` as taken.
    pub fn take(&mut self, name: &str) {
        self.taken.insert(name.to_string());
    }

    /// Is `name` taken?
    pub fn contains(&self, name: &str) -> bool {
        self.taken.contains(name)
    }

    /// A fresh identifier based on `base`, made unique with a numeric suffix.
    pub fn fresh(&mut self, base: &str) -> String {
        let base = identifier(base);
        if self.taken.insert(base.clone()) {
            return base;
        }
        let mut k = self.next.get(&base).copied().unwrap_or(2);
        let name = loop {
            let name = format!("{base}_{k}");
            k += 1;
            if self.taken.insert(name.clone()) {
                break name;
            }
        };
        self.next.insert(base, k);
        name
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn snake_case() {
        assert_eq!(snake("Omega"), "omega");
        assert_eq!(snake("dU"), "d_u");
        assert_eq!(snake("RigidBody"), "rigid_body");
        assert_eq!(snake("R"), "r");
        assert_eq!(snake("k0"), "k0");
        assert_eq!(snake("HTTPServer"), "http_server");
    }

    #[test]
    fn fresh_names_are_unique_and_not_keywords() {
        let mut s = Scope::with(&["x"]);
        assert_eq!(s.fresh("x"), "x_2");
        assert_eq!(s.fresh("type"), "type_");
        assert_eq!(s.fresh("r"), "r");
        assert_eq!(s.fresh("r"), "r_2");
        assert_eq!(s.fresh("_"), "v_");
        assert_eq!(s.fresh("self"), "self_");
        assert_eq!(s.fresh("7up"), "v7up");
    }
}
