//! The functions a node can apply: [`Func`] of one argument, [`Func2`] of two, each with its
//! value in f64 and its local derivative (the derivative rules live here, next to the
//! definitions; `derive` applies them through the chain rule).
//!
//! The elliptic functions take the **parameter m = k²** (A&S 16–17), as `lasalle_elliptic`
//! (re-exported as `lasalle_runtime::elliptic`) does, and are evaluated by its kernels.
//! Their derivatives are taken with respect to the first argument only: ∂/∂m involves the
//! incomplete integral of the second kind and is not implemented, so the DSL refuses a
//! parameter m that depends on the state (the only variables derivatives are taken for), see
//! `model::expr`.

use super::{Graph, Id, Rational};
use lasalle_elliptic::{ellipf, ellipj, ellipk};

/// Functions of one argument.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Func {
    /// eˣ
    Exp,
    /// natural logarithm
    Ln,
    /// sine
    Sin,
    /// cosine
    Cos,
    /// complete elliptic integral of the first kind K(m), parameter m = k²
    EllipK,
}

impl Func {
    /// The name used in model files.
    pub const fn name(self) -> &'static str {
        match self {
            Func::Exp => "exp",
            Func::Ln => "log",
            Func::Sin => "sin",
            Func::Cos => "cos",
            Func::EllipK => "ellipk",
        }
    }

    /// Applies the function to an f64 (as the emitted code computes it).
    pub fn apply(self, x: f64) -> f64 {
        match self {
            Func::Exp => x.exp(),
            Func::Ln => x.ln(),
            Func::Sin => x.sin(),
            Func::Cos => x.cos(),
            Func::EllipK => ellipk(x),
        }
    }

    /// Is the argument a parameter m that derivatives must not see vary (see the module docs)?
    pub fn takes_parameter(self) -> bool {
        self == Func::EllipK
    }

    /// f′(a) for the node `id = f(a)`; `None` for K(m), whose derivative is not implemented
    /// (its argument never depends on the state).
    pub fn derivative(self, g: &mut Graph, id: Id, a: Id) -> Option<Id> {
        Some(match self {
            Func::Exp => id,
            Func::Ln => g.pow(a, Rational::int(-1)),
            Func::Sin => g.func(Func::Cos, a),
            Func::Cos => {
                let s = g.func(Func::Sin, a);
                g.neg(s)
            }
            Func::EllipK => return None,
        })
    }
}

/// Functions of two arguments: the Jacobi elliptic functions of (u | m) and the incomplete
/// elliptic integral F(φ | m), all with the parameter m = k² second.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Func2 {
    /// sn(u | m)
    Sn,
    /// cn(u | m)
    Cn,
    /// dn(u | m)
    Dn,
    /// F(φ | m) = ∫₀^φ dθ / √(1 − m sin²θ)
    EllipF,
}

impl Func2 {
    /// The name used in model files.
    pub const fn name(self) -> &'static str {
        match self {
            Func2::Sn => "sn",
            Func2::Cn => "cn",
            Func2::Dn => "dn",
            Func2::EllipF => "ellipf",
        }
    }

    /// Applies the function to f64 arguments (as the emitted code computes it).
    pub fn apply(self, x: f64, m: f64) -> f64 {
        match self {
            Func2::Sn => ellipj(x, m).sn,
            Func2::Cn => ellipj(x, m).cn,
            Func2::Dn => ellipj(x, m).dn,
            Func2::EllipF => ellipf(x, m),
        }
    }

    /// ∂f/∂x for the node `f(x, m)` (m held fixed): sn′ = cn dn, cn′ = −sn dn,
    /// dn′ = −m sn cn (A&S 16.16), F′ = 1/√(1 − m sin²φ) (A&S 17.2).
    pub fn derivative(self, g: &mut Graph, x: Id, m: Id) -> Id {
        let jacobi = |g: &mut Graph, f| g.func2(f, x, m);
        match self {
            Func2::Sn => {
                let (c, d) = (jacobi(g, Func2::Cn), jacobi(g, Func2::Dn));
                g.mul(&[c, d])
            }
            Func2::Cn => {
                let (s, d) = (jacobi(g, Func2::Sn), jacobi(g, Func2::Dn));
                let p = g.mul(&[s, d]);
                g.neg(p)
            }
            Func2::Dn => {
                let (s, c) = (jacobi(g, Func2::Sn), jacobi(g, Func2::Cn));
                let p = g.mul(&[m, s, c]);
                g.neg(p)
            }
            Func2::EllipF => {
                let s = g.func(Func::Sin, x);
                let s2 = g.pow(s, Rational::int(2));
                let ms2 = g.mul(&[m, s2]);
                let one = g.num(1.0);
                let delta2 = g.sub(one, ms2);
                g.pow(delta2, Rational::new(-1, 2))
            }
        }
    }
}
