//! Evaluation of the DAG over any number-like type: f64 for checks, truncated power series
//! for Taylor expansion (normal forms), intervals or jets later.

use super::{Func, Func2, Graph, Id, Input, Node, Rational};

/// What the DAG needs from a value type to be evaluated over it.
///
/// `powf` is only called with rational exponents that are not integers (±½, ±3/2, …); the
/// exponent is exact, so extended-precision types can compute with it exactly.
pub trait Scalar: Clone {
    /// A constant.
    fn from_f64(c: f64) -> Self;
    /// self + o
    fn add(&self, o: &Self) -> Self;
    /// self · o
    fn mul(&self, o: &Self) -> Self;
    /// 1 / self
    fn recip(&self) -> Self;
    /// selfⁿ for an integer n (negative allowed).
    fn powi(&self, n: i32) -> Self;
    /// selfᵖ for a non-integer rational p.
    fn powf(&self, p: Rational) -> Self;
    /// eˢᵉˡᶠ
    fn exp(&self) -> Self;
    /// ln(self)
    fn ln(&self) -> Self;
    /// sin(self)
    fn sin(&self) -> Self;
    /// cos(self)
    fn cos(&self) -> Self;
    /// sn, cn, dn of (self | m), parameter m = k².
    ///
    /// The default is NaN: a type without elliptic functions. The truncated series of the
    /// normal-form crate have none, and it refuses models that call them before evaluating.
    fn jacobi(&self, _m: &Self) -> [Self; 3] {
        let nan = Self::from_f64(f64::NAN);
        [nan.clone(), nan.clone(), nan]
    }
    /// K(self), parameter m = self (default NaN, as [`Scalar::jacobi`]).
    fn ellipk(&self) -> Self {
        Self::from_f64(f64::NAN)
    }
    /// F(self | m), parameter m (default NaN, as [`Scalar::jacobi`]).
    fn ellipf(&self, _m: &Self) -> Self {
        Self::from_f64(f64::NAN)
    }
    /// −self
    fn neg(&self) -> Self {
        self.mul(&Self::from_f64(-1.0))
    }
    /// self − o
    fn sub(&self, o: &Self) -> Self {
        self.add(&o.neg())
    }
    /// self / o
    fn div(&self, o: &Self) -> Self {
        self.mul(&o.recip())
    }
    /// √self
    fn sqrt(&self) -> Self {
        self.powf(Rational::new(1, 2))
    }
    /// ∛self (the emitted code's `cbrt`, real for negative arguments in f64).
    fn cbrt(&self) -> Self {
        self.powf(Rational::new(1, 3))
    }
}

impl Scalar for f64 {
    fn from_f64(c: f64) -> Self {
        c
    }
    fn add(&self, o: &Self) -> Self {
        self + o
    }
    fn mul(&self, o: &Self) -> Self {
        self * o
    }
    fn recip(&self) -> Self {
        1.0 / self
    }
    // One IEEE operation each (the defaults round twice: a · (1/b)).
    fn neg(&self) -> Self {
        -self
    }
    fn sub(&self, o: &Self) -> Self {
        self - o
    }
    fn div(&self, o: &Self) -> Self {
        self / o
    }
    fn powi(&self, n: i32) -> Self {
        f64::powi(*self, n)
    }
    fn powf(&self, p: Rational) -> Self {
        match (p.num, p.den) {
            (1, 2) => f64::sqrt(*self),
            (-1, 2) => 1.0 / f64::sqrt(*self),
            _ => f64::powf(*self, p.to_f64()),
        }
    }
    fn sqrt(&self) -> Self {
        f64::sqrt(*self)
    }
    fn cbrt(&self) -> Self {
        f64::cbrt(*self)
    }
    fn exp(&self) -> Self {
        f64::exp(*self)
    }
    fn ln(&self) -> Self {
        f64::ln(*self)
    }
    fn sin(&self) -> Self {
        f64::sin(*self)
    }
    fn cos(&self) -> Self {
        f64::cos(*self)
    }
    fn jacobi(&self, m: &Self) -> [Self; 3] {
        let j = lasalle_elliptic::ellipj(*self, *m);
        [j.sn, j.cn, j.dn]
    }
    fn ellipk(&self) -> Self {
        lasalle_elliptic::ellipk(*self)
    }
    fn ellipf(&self, m: &Self) -> Self {
        lasalle_elliptic::ellipf(*self, *m)
    }
}

impl Func {
    /// The function over any [`Scalar`].
    pub fn eval<S: Scalar>(self, a: &S) -> S {
        match self {
            Func::Exp => a.exp(),
            Func::Ln => a.ln(),
            Func::Sin => a.sin(),
            Func::Cos => a.cos(),
            Func::EllipK => a.ellipk(),
        }
    }
}

impl Func2 {
    /// The function over any [`Scalar`].
    pub fn eval<S: Scalar>(self, x: &S, m: &S) -> S {
        match self {
            Func2::Sn | Func2::Cn | Func2::Dn => {
                let [sn, cn, dn] = x.jacobi(m);
                match self {
                    Func2::Sn => sn,
                    Func2::Cn => cn,
                    _ => dn,
                }
            }
            Func2::EllipF => x.ellipf(m),
        }
    }
}

impl Graph {
    /// Evaluates `outputs`, asking `input` for the value of each leaf once.
    ///
    /// Every reachable node is evaluated exactly once, in topological order.
    pub fn eval<S: Scalar>(&self, outputs: &[Id], input: &mut dyn FnMut(Input) -> S) -> Vec<S> {
        let order = self.reachable(outputs);
        let mut slot = vec![usize::MAX; self.len()];
        let mut values: Vec<S> = Vec::with_capacity(order.len());
        for &id in &order {
            let v = |k: &Id| &values[slot[k.index()]];
            let value = match self.node(id) {
                Node::Num(b) => S::from_f64(f64::from_bits(*b)),
                Node::Input(i) => input(*i),
                Node::Add(c) => c[1..].iter().fold(v(&c[0]).clone(), |acc, k| acc.add(v(k))),
                Node::Mul(c) => c[1..].iter().fold(v(&c[0]).clone(), |acc, k| acc.mul(v(k))),
                Node::Pow(b, e) if e.is_int() => v(b).powi(e.num),
                Node::Pow(b, e) => v(b).powf(*e),
                Node::Func(f, a) => f.eval(v(a)),
                Node::Func2(f, [x, m]) => f.eval(v(x), v(m)),
            };
            slot[id.index()] = values.len();
            values.push(value);
        }
        outputs
            .iter()
            .map(|o| values[slot[o.index()]].clone())
            .collect()
    }

    /// Evaluates in f64 with inputs from a closure.
    pub fn eval_f64(&self, outputs: &[Id], input: &mut dyn FnMut(Input) -> f64) -> Vec<f64> {
        self.eval(outputs, input)
    }

    /// Evaluates `root` in f64 together with a rounding-error scale: a bound on the magnitude
    /// of the terms whose cancellation produced the value (Σ|terms| through sums, Π through
    /// products, amplified by exponents). A value that should vanish is "zero up to rounding"
    /// when it is small relative to this scale.
    pub fn eval_with_scale(&self, root: Id, input: &mut dyn FnMut(Input) -> f64) -> (f64, f64) {
        let order = self.reachable(&[root]);
        let mut val = vec![0.0; self.len()];
        let mut mag = vec![0.0; self.len()];
        for &id in &order {
            let (v, m) = match self.node(id) {
                Node::Num(b) => {
                    let x = f64::from_bits(*b);
                    (x, x.abs())
                }
                Node::Input(i) => {
                    let x = input(*i);
                    (x, x.abs())
                }
                Node::Add(c) => (
                    c.iter().map(|k| val[k.index()]).sum(),
                    c.iter().map(|k| mag[k.index()]).sum(),
                ),
                Node::Mul(c) => (
                    c.iter().map(|k| val[k.index()]).product(),
                    c.iter().map(|k| mag[k.index()]).product(),
                ),
                Node::Pow(b, e) => {
                    let (bv, bm) = (val[b.index()], mag[b.index()]);
                    let v = if e.is_int() {
                        bv.powi(e.num)
                    } else {
                        bv.powf(e.to_f64())
                    };
                    // relative error of bᵉ ≈ |e| · relative error of b
                    let amplification = (e.to_f64().abs() * bm / bv.abs()).max(1.0);
                    (v, v.abs() * amplification)
                }
                Node::Func(f, a) => {
                    let (av, am) = (val[a.index()], mag[a.index()]);
                    let v = f.apply(av);
                    let m = match f {
                        Func::Exp => v.abs() * am.max(1.0),
                        Func::Ln => v.abs().max(am / av.abs()),
                        Func::Sin | Func::Cos => v.abs().max(am),
                        // K grows like ½ ln(16/(1 − m)): bounded by its value and the input's
                        Func::EllipK => v.abs().max(am),
                    };
                    (v, m)
                }
                Node::Func2(f, [x, m]) => {
                    let (xv, xm) = (val[x.index()], mag[x.index()]);
                    let v = f.apply(xv, val[m.index()]);
                    // |sn|, |cn|, |dn| ≤ 1 with slopes ≤ 1; F grows at most like its argument
                    // times 1/√(1 − m) — the scale of the argument carries the rounding.
                    (v, v.abs().max(xm))
                }
            };
            val[id.index()] = v;
            mag[id.index()] = m;
        }
        (val[root.index()], mag[root.index()])
    }
}
