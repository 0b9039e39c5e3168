//! The names and tables of loaded models' descriptions, stored once per distinct content for
//! the life of the process. [`ModelInfo`](lasalle_runtime::ModelInfo) hands them out as
//! `'static`, as a compiled model's constants are; interning them means a process that loads
//! the same model again and again (a notebook, a sweep over files) holds one copy, not one per
//! load.

use std::any::{Any, TypeId};
use std::collections::{HashMap, HashSet};
use std::fmt::Debug;
use std::sync::{Mutex, MutexGuard, OnceLock};

#[derive(Default)]
struct Interner {
    names: HashSet<&'static str>,
    /// By element type and content (the `Debug` text of the table).
    tables: HashMap<(TypeId, String), &'static (dyn Any + Send + Sync)>,
}

fn interner() -> MutexGuard<'static, Interner> {
    static INTERNER: OnceLock<Mutex<Interner>> = OnceLock::new();
    INTERNER
        .get_or_init(Default::default)
        .lock()
        // the maps are consistent after every statement: a panic elsewhere leaves them usable
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// `name`, stored once per distinct string.
pub(crate) fn name(name: &str) -> &'static str {
    let mut interner = interner();
    if let Some(&stored) = interner.names.get(name) {
        return stored;
    }
    let stored: &'static str = Box::leak(name.into());
    interner.names.insert(stored);
    stored
}

/// `table`, stored once per distinct content. Two tables are the same when their `Debug` texts
/// are: for the plain data of a model's description (names, shapes, offsets, numbers printed
/// to the last bit) that is equality of every field.
pub(crate) fn table<T: Debug + Send + Sync + 'static>(mut table: Vec<T>) -> &'static [T] {
    let key = (TypeId::of::<T>(), format!("{table:?}"));
    let mut interner = interner();
    if let Some(stored) = interner.tables.get(&key) {
        return stored
            .downcast_ref::<Vec<T>>()
            .expect("a table is stored under its own element type");
    }
    table.shrink_to_fit();
    let stored: &'static Vec<T> = Box::leak(Box::new(table));
    interner.tables.insert(key, stored);
    stored
}

/// How much the loaded models' descriptions hold for the life of the process
/// ([`interned`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Interned {
    /// Distinct names (models, state and parameter slots, gains, points, presets, guards,
    /// events, …).
    pub names: usize,
    /// Distinct tables (of slots, invariants, gains, presets, events, …).
    pub tables: usize,
}

/// The names and tables the descriptions of the models loaded so far hold: loading a model
/// again adds nothing.
pub fn interned() -> Interned {
    let interner = interner();
    Interned {
        names: interner.names.len(),
        tables: interner.tables.len(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_content_is_stored_once() {
        let a = name("an interned name");
        let b = name(&String::from("an interned name"));
        assert!(std::ptr::eq(a, b));
        assert!(!std::ptr::eq(a, name("another interned name")));
        let x = table(vec![1.5f64, -0.0]);
        let y = table(vec![1.5f64, -0.0]);
        assert!(std::ptr::eq(x, y));
        // 0.0 and -0.0 are different tables; so are the same numbers as another type
        assert!(!std::ptr::eq(x, table(vec![1.5f64, 0.0])));
        let z = table(vec![1.5f32, -0.0]);
        assert_eq!(z, [1.5f32, -0.0]);
        assert_eq!(x, [1.5, -0.0]);
    }
}
