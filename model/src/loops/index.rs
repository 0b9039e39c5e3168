//! The index structure of a loop family, kept for the back ends that write loops out (the
//! emitted Rust): the ranges and conditions of its head and, per slot, the subscript as an
//! integer expression of the indices, so that `sum(i in 0..n, j in i+1..n: … q[i] …)` can be
//! written `for i in 0..n { for j in (i + 1)..n { … x[3 * i] … } }` instead of as a table.
//!
//! The structure is recorded at lowering only where it reproduces the enumerated tuples and
//! the gathered indices exactly (both are checked against the tables, tuple by tuple); where
//! it cannot (a subscript or a bound the integer expressions below do not cover), it is
//! `None` and a back end uses the tables.

/// An integer expression of a family's indices (`i + 1`, `(i + 1) % n`, `3`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Ix {
    /// A whole number (a literal, or a constant such as a size parameter, by its value).
    Int(i64),
    /// The k-th index of the family's ranges, outermost first.
    Var(usize),
    /// a + b
    Add(Box<Ix>, Box<Ix>),
    /// a − b
    Sub(Box<Ix>, Box<Ix>),
    /// a · b
    Mul(Box<Ix>, Box<Ix>),
    /// The non-negative remainder of a by b (b > 0), as the DSL's `%`.
    Rem(Box<Ix>, Box<Ix>),
}

impl Ix {
    /// The value for the bound indices `vars` (`None` on overflow, a remainder by a
    /// non-positive number or an unbound index).
    pub fn eval(&self, vars: &[i64]) -> Option<i64> {
        let two = |a: &Ix, b: &Ix| Some((a.eval(vars)?, b.eval(vars)?));
        match self {
            Ix::Int(k) => Some(*k),
            Ix::Var(k) => vars.get(*k).copied(),
            Ix::Add(a, b) => two(a, b).and_then(|(a, b)| a.checked_add(b)),
            Ix::Sub(a, b) => two(a, b).and_then(|(a, b)| a.checked_sub(b)),
            Ix::Mul(a, b) => two(a, b).and_then(|(a, b)| a.checked_mul(b)),
            Ix::Rem(a, b) => two(a, b).and_then(|(a, b)| (b > 0).then(|| a.rem_euclid(b))),
        }
    }

    /// Is every intermediate value non-negative for these indices (so the expression can be
    /// computed in unsigned integers, where `%` is the DSL's remainder)?
    pub fn non_negative(&self, vars: &[i64]) -> bool {
        let ok = self.eval(vars).is_some_and(|v| v >= 0);
        ok && match self {
            Ix::Int(_) | Ix::Var(_) => true,
            Ix::Add(a, b) | Ix::Sub(a, b) | Ix::Mul(a, b) | Ix::Rem(a, b) => {
                a.non_negative(vars) && b.non_negative(vars)
            }
        }
    }

    /// Does the expression read index k?
    pub fn reads(&self, k: usize) -> bool {
        match self {
            Ix::Int(_) => false,
            Ix::Var(v) => *v == k,
            Ix::Add(a, b) | Ix::Sub(a, b) | Ix::Mul(a, b) | Ix::Rem(a, b) => {
                a.reads(k) || b.reads(k)
            }
        }
    }
}

/// A comparison in a family's condition.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Compare {
    /// `==`
    Eq,
    /// `!=`
    Ne,
    /// `<`
    Lt,
    /// `<=`
    Le,
    /// `>`
    Gt,
    /// `>=`
    Ge,
}

impl Compare {
    /// Does `a op b` hold?
    pub fn holds(self, a: i64, b: i64) -> bool {
        match self {
            Compare::Eq => a == b,
            Compare::Ne => a != b,
            Compare::Lt => a < b,
            Compare::Le => a <= b,
            Compare::Gt => a > b,
            Compare::Ge => a >= b,
        }
    }

    /// The operator as written (`!=`).
    pub fn symbol(self) -> &'static str {
        match self {
            Compare::Eq => "==",
            Compare::Ne => "!=",
            Compare::Lt => "<",
            Compare::Le => "<=",
            Compare::Gt => ">",
            Compare::Ge => ">=",
        }
    }
}

/// One clause of a family's head, in order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LoopClause {
    /// `var in start..end`; `start` and `end` read the indices bound before.
    Range {
        /// The index's name.
        var: String,
        /// First value.
        start: Ix,
        /// One past the last value.
        end: Ix,
    },
    /// Only the tuples where `lhs op rhs`.
    Cond {
        /// Left side.
        lhs: Ix,
        /// The comparison.
        op: Compare,
        /// Right side.
        rhs: Ix,
    },
}

/// Where a slot reads, per tuple: `base + stride · member`, `member` an expression of the
/// indices (`q[i + 1]` of a `vec3[n]` state at offset 15, component 2: base 17, stride 3,
/// member `i + 1`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SlotIndex {
    /// The index of member 0's component.
    pub base: i64,
    /// Components per member.
    pub stride: i64,
    /// The member read.
    pub member: Ix,
}

impl SlotIndex {
    /// The flat index for the bound indices `vars`.
    pub fn eval(&self, vars: &[i64]) -> Option<i64> {
        self.member
            .eval(vars)?
            .checked_mul(self.stride)?
            .checked_add(self.base)
    }
}

/// The index tuples of `clauses`, in order (outermost index slowest); `None` if a bound
/// does not evaluate or there are more than `limit` tuples.
pub fn tuples(clauses: &[LoopClause], limit: usize) -> Option<Vec<Vec<i64>>> {
    fn go(
        clauses: &[LoopClause],
        bound: &mut Vec<i64>,
        out: &mut Vec<Vec<i64>>,
        limit: usize,
    ) -> Option<()> {
        let Some((first, rest)) = clauses.split_first() else {
            if out.len() >= limit {
                return None;
            }
            out.push(bound.clone());
            return Some(());
        };
        match first {
            LoopClause::Range { start, end, .. } => {
                let (a, b) = (start.eval(bound)?, end.eval(bound)?);
                for v in a..b {
                    bound.push(v);
                    let r = go(rest, bound, out, limit);
                    bound.pop();
                    r?;
                }
            }
            LoopClause::Cond { lhs, op, rhs } => {
                if op.holds(lhs.eval(bound)?, rhs.eval(bound)?) {
                    go(rest, bound, out, limit)?;
                }
            }
        }
        Some(())
    }
    let mut out = Vec::new();
    go(clauses, &mut Vec::new(), &mut out, limit)?;
    Some(out)
}
