//! Rust identifiers for model names: snake_case-ish, unique within a scope, never a keyword.

use std::collections::HashSet;

const RUST_KEYWORDS: &[&str] = &[
    "as", "async", "await", "break", "const", "continue", "crate", "dyn", "else", "enum", "extern",
    "false", "fn", "for", "if", "impl", "in", "let", "loop", "match", "mod", "move", "mut", "pub",
    "ref", "return", "self", "Self", "static", "struct", "super", "trait", "true", "type",
    "unsafe", "use", "where", "while", "abstract", "become", "box", "do", "final", "macro",
    "override", "priv", "typeof", "unsized", "virtual", "yield", "try", "gen",
];

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
    if base.is_empty() || base.starts_with(|c: char| c.is_ascii_digit()) {
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
}

impl Scope {
    /// A scope where `reserved` are already taken (function arguments, `self`).
    pub fn with(reserved: &[&str]) -> Self {
        Scope {
            taken: reserved.iter().map(|s| s.to_string()).collect(),
        }
    }

    /// A fresh identifier based on `base`, made unique with a numeric suffix.
    pub fn fresh(&mut self, base: &str) -> String {
        let base = identifier(base);
        let mut name = base.clone();
        let mut k = 2;
        while self.taken.contains(&name) {
            name = format!("{base}_{k}");
            k += 1;
        }
        self.taken.insert(name.clone());
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
    }
}
