//! Lagrange multipliers across coordinate systems (the fourth paper of NASA TM X-53478, on
//! transforming state variables and their Lagrange multipliers between coordinate systems).
//!
//! A coordinate change y = h(x) between two descriptions of the same state, x = (x₁ … xₙ) and
//! y = (y₁ … yₙ), carries the multipliers σ of the y-frame to those of the x-frame by
//!
//! ```text
//! λᵢ = σⱼ ∂hⱼ/∂xᵢ         (λ = Jᵀσ, J = ∂h/∂x)
//! ```
//!
//! and, inversely, σ = J⁻ᵀλ. Under it the function L = σ·g(y) becomes λ·f(x) with
//! f = J⁻¹ g(h(x)), and the Euler–Lagrange equations σ̇ = −∂(σ·g)/∂y become
//! λ̇ = −∂(λ·f)/∂x: the change is a cotangent lift, so the two Hamiltonian systems are the
//! same flow written in two charts. Differentiating λ = Jᵀσ along the flow gives the
//! transformed adjoint equations directly,
//!
//! ```text
//! λ̇ᵢ = σ̇ⱼ ∂hⱼ/∂xᵢ + σⱼ (∂²hⱼ/∂xᵢ∂xₖ) ẋₖ,
//! ```
//!
//! which [`CoordinateChange`] builds symbolically in the generator's expression IR
//! (`lasalle_model::ir`): J by the IR's forward-mode [`jacobian`], λ̇ by differentiating the
//! expression λ(x, σ) along (ẋ, σ̇). [`EulerLagrange`] builds a frame's own equations
//! ẋ = f(x, λ), λ̇ = −∂(λ·f)/∂x from its f, so the transformed equations can be compared with
//! the ones derived in the other frame.
//!
//! Where J is singular the inverse transformation does not exist; [`CoordinateChange::check`]
//! refuses such a point with [`MultiplierError::Singular`], which names the point, the
//! direction J maps to zero and the vanishing factor: the subexpression of J (a node of its
//! DAG, e.g. `cos(γ)` or `v` in the flight-path frame) that is zero at the point and without
//! whose vanishing J would be regular there — found by moving each vanishing node off zero in
//! every place it occurs and asking whether J becomes regular.
//!
//! The paper's frames — the plumb-line frame (x, y, z, ẋ, ẏ, ż) and the spherical
//! flight-path frame (r, φ, θ, v, γ, δ) of a thrusting vehicle — are [`flight_path`]. The
//! derivations and the measured residuals are in `docs/multipliers.md`.

pub mod flight_path;

use std::fmt;

use lasalle_model::ir::{diff, jacobian, Graph, Id, Input, Node};
use nalgebra::{DMatrix, DVector};

/// A point is singular when the smallest singular value of J is below this fraction of the
/// largest.
pub const SINGULAR_RCOND: f64 = 1e-13;

/// A factor of a column vanishes when its value at the point is below this, relative to the
/// largest coordinate of the point (and 1).
const VANISHING: f64 = 1e-12;

/// Why a coordinate change cannot be built or applied.
#[derive(Clone, Debug, PartialEq)]
pub enum MultiplierError {
    /// The coordinate change or a point does not have the shape the frames give.
    Shape(String),
    /// J = ∂h/∂x is singular at the point.
    Singular {
        /// The point, as (name, value) in the x-frame.
        point: Vec<(String, f64)>,
        /// The vanishing factors: subexpressions of J that vanish at the point and without
        /// whose vanishing J would be regular there, rendered with the frame's names, with
        /// their values.
        factors: Vec<(String, f64)>,
        /// The smallest singular value of J over its largest.
        rcond: f64,
        /// The direction in the x-frame that J maps to 0 (the right singular vector of the
        /// smallest singular value), as (name, component) for the components above 1e-8.
        null: Vec<(String, f64)>,
    },
}

impl fmt::Display for MultiplierError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MultiplierError::Shape(m) => f.write_str(m),
            MultiplierError::Singular {
                point,
                factors,
                rcond,
                null,
            } => {
                let at: Vec<String> = point.iter().map(|(n, v)| format!("{n} = {v}")).collect();
                write!(
                    f,
                    "the coordinate change is singular at ({}): σ_min/σ_max of ∂h/∂x is {rcond:.3e}",
                    at.join(", ")
                )?;
                let dir: Vec<String> = null.iter().map(|(n, v)| format!("d{n} = {v:.6}")).collect();
                if factors.is_empty() {
                    write!(
                        f,
                        "; no factor of a column vanishes there, the columns are dependent along ({})",
                        dir.join(", ")
                    )?;
                } else {
                    let which: Vec<String> = factors
                        .iter()
                        .map(|(e, v)| format!("{e} = {v:.3e}"))
                        .collect();
                    write!(
                        f,
                        "; the factor{} {} vanish{} there (∂h/∂x is regular where {} nonzero), the columns are dependent along ({})",
                        if factors.len() > 1 { "s" } else { "" },
                        which.join(", "),
                        if factors.len() > 1 { "" } else { "es" },
                        if factors.len() > 1 { "they are" } else { "it is" },
                        dir.join(", ")
                    )?;
                }
                f.write_str(
                    "; the multipliers of this frame are not determined there — describe the state in the other frame or move off the singular set",
                )
            }
        }
    }
}

impl std::error::Error for MultiplierError {}

/// The value of each input slot: `State(i)` = x, `Symbol(k)` = the symbols, `Param(k)` = the
/// parameters; any other input is NaN.
fn inputs<'a>(x: &'a [f64], sym: &'a [f64], par: &'a [f64]) -> impl FnMut(Input) -> f64 + 'a {
    move |i| match i {
        Input::State(k) => x.get(k as usize).copied().unwrap_or(f64::NAN),
        Input::Symbol(k) => sym.get(k as usize).copied().unwrap_or(f64::NAN),
        Input::Param(k) => par.get(k as usize).copied().unwrap_or(f64::NAN),
        _ => f64::NAN,
    }
}

/// The value of every node of `order` (a topological order) at the point x, with one node's
/// value replaced (`over`), indexed by Id.
fn eval_nodes(g: &Graph, order: &[Id], x: &[f64], over: Option<(Id, f64)>) -> Vec<f64> {
    let mut val = vec![0.0; g.len()];
    let mut input = inputs(x, &[], &[]);
    for &id in order {
        let v = match g.node(id) {
            Node::Num(b) => f64::from_bits(*b),
            Node::Input(i) => input(*i),
            Node::Add(c) => c.iter().map(|k| val[k.index()]).sum(),
            Node::Mul(c) => c.iter().map(|k| val[k.index()]).product(),
            Node::Pow(b, e) => {
                if e.is_int() {
                    val[b.index()].powi(e.num)
                } else {
                    val[b.index()].powf(e.to_f64())
                }
            }
            Node::Func(f, a) => f.apply(val[a.index()]),
            Node::Func2(f, [a, m]) => f.apply(val[a.index()], val[m.index()]),
        };
        val[id.index()] = match over {
            Some((o, moved)) if o == id => moved,
            _ => v,
        };
    }
    val
}

/// An expression rendered with the frame's names: `State(i)` as `names[i]`, `Symbol(k)` as
/// `s{k}`, `Param(k)` as `p{k}`.
pub fn render(g: &Graph, id: Id, names: &[String]) -> String {
    match g.node(id) {
        Node::Num(b) => format!("{}", f64::from_bits(*b)),
        Node::Input(Input::State(i)) => names
            .get(*i as usize)
            .cloned()
            .unwrap_or_else(|| format!("x{i}")),
        Node::Input(Input::Symbol(i)) => format!("s{i}"),
        Node::Input(Input::Param(i)) => format!("p{i}"),
        Node::Input(other) => format!("{other:?}"),
        Node::Add(c) => format!(
            "({})",
            c.iter()
                .map(|&k| render(g, k, names))
                .collect::<Vec<_>>()
                .join(" + ")
        ),
        Node::Mul(c) => c
            .iter()
            .map(|&k| render(g, k, names))
            .collect::<Vec<_>>()
            .join("·"),
        Node::Pow(b, e) => format!("{}^({e})", render(g, *b, names)),
        Node::Func(f, a) => format!("{}({})", f.name(), render(g, *a, names)),
        Node::Func2(f, [a, m]) => format!(
            "{}({}, {})",
            f.name(),
            render(g, *a, names),
            render(g, *m, names)
        ),
    }
}

/// A coordinate change y = h(x) in the expression IR, with its Jacobian, the multipliers
/// λ = Jᵀσ and their rates as expressions.
///
/// Inputs: `State(i)` is xᵢ; in [`multipliers`](Self::multiplier_exprs) `Symbol(j)` is σⱼ; in
/// the rates `Symbol(n + k)` is ẋₖ and `Symbol(2n + j)` is σ̇ⱼ.
#[derive(Clone)]
pub struct CoordinateChange {
    graph: Graph,
    from: Vec<String>,
    to: Vec<String>,
    h: Vec<Id>,
    /// J[j][i] = ∂hⱼ/∂xᵢ.
    jac: Vec<Vec<Id>>,
    /// λᵢ(x, σ).
    lambda: Vec<Id>,
    /// λ̇ᵢ(x, σ, ẋ, σ̇).
    lambda_rate: Vec<Id>,
}

impl CoordinateChange {
    /// The change h: x ↦ y given by `h[j]`, an expression in `State(0 … n−1)` = x, in `graph`;
    /// `from` and `to` name the coordinates of the two frames.
    pub fn new(
        mut graph: Graph,
        from: &[&str],
        to: &[&str],
        h: Vec<Id>,
    ) -> Result<CoordinateChange, MultiplierError> {
        let n = from.len();
        if n == 0 || to.len() != n || h.len() != n {
            return Err(MultiplierError::Shape(format!(
                "a coordinate change needs as many coordinates on both sides as expressions: {} → {} with {} expressions",
                n,
                to.len(),
                h.len()
            )));
        }
        for (j, &e) in h.iter().enumerate() {
            if graph.depends_on(e, |i| !matches!(i, Input::State(k) if (k as usize) < n)) {
                return Err(MultiplierError::Shape(format!(
                    "the expression of {} reads an input other than the {n} coordinates ({}): {}",
                    to[j],
                    from.join(", "),
                    graph.display(e)
                )));
            }
        }
        let vars: Vec<Input> = (0..n as u32).map(Input::State).collect();
        let jac = jacobian(&mut graph, &h, &vars);
        let sigma: Vec<Id> = (0..n as u32)
            .map(|j| graph.input(Input::Symbol(j)))
            .collect();
        let lambda: Vec<Id> = (0..n)
            .map(|i| {
                let terms: Vec<Id> = (0..n).map(|j| graph.mul(&[sigma[j], jac[j][i]])).collect();
                graph.add(&terms)
            })
            .collect();
        let lambda_rate = Self::rates(&mut graph, &lambda, n);
        Ok(CoordinateChange {
            graph,
            from: from.iter().map(|s| s.to_string()).collect(),
            to: to.iter().map(|s| s.to_string()).collect(),
            h,
            jac,
            lambda,
            lambda_rate,
        })
    }

    /// λ̇ᵢ = Σₖ ∂λᵢ/∂xₖ ẋₖ + Σⱼ ∂λᵢ/∂σⱼ σ̇ⱼ with ẋₖ = `Symbol(n + k)`, σ̇ⱼ = `Symbol(2n + j)`.
    fn rates(graph: &mut Graph, lambda: &[Id], n: usize) -> Vec<Id> {
        let mut terms: Vec<Vec<Id>> = vec![Vec::with_capacity(2 * n); lambda.len()];
        // (the variable, the symbol of its rate): xₖ with ẋₖ, then σⱼ with σ̇ⱼ
        let pairs = (0..n)
            .map(|k| (Input::State(k as u32), n + k))
            .chain((0..n).map(|j| (Input::Symbol(j as u32), 2 * n + j)));
        for (var, rate) in pairs {
            // one memo per variable: `diff` memoizes by node
            let mut memo = Default::default();
            let r = graph.input(Input::Symbol(rate as u32));
            for (i, &l) in lambda.iter().enumerate() {
                let d = diff(graph, l, var, &mut memo);
                terms[i].push(graph.mul(&[d, r]));
            }
        }
        terms.iter().map(|t| graph.add(t)).collect()
    }

    /// The dimension n.
    pub fn dim(&self) -> usize {
        self.from.len()
    }

    /// The names of the x-frame's coordinates.
    pub fn from_names(&self) -> &[String] {
        &self.from
    }

    /// The names of the y-frame's coordinates.
    pub fn to_names(&self) -> &[String] {
        &self.to
    }

    /// The expression IR holding h, J, λ and λ̇.
    pub fn graph(&self) -> &Graph {
        &self.graph
    }

    /// ∂hⱼ/∂xᵢ as an expression (row j, column i).
    pub fn jacobian_expr(&self, j: usize, i: usize) -> Id {
        self.jac[j][i]
    }

    /// λᵢ(x, σ) as expressions (`Symbol(j)` = σⱼ).
    pub fn multiplier_exprs(&self) -> &[Id] {
        &self.lambda
    }

    fn point(&self, x: &[f64]) -> Result<(), MultiplierError> {
        if x.len() != self.dim() || x.iter().any(|v| !v.is_finite()) {
            return Err(MultiplierError::Shape(format!(
                "a point of ({}) needs {} finite values, got {x:?}",
                self.from.join(", "),
                self.dim()
            )));
        }
        Ok(())
    }

    /// y = h(x).
    pub fn apply(&self, x: &[f64]) -> Result<Vec<f64>, MultiplierError> {
        self.point(x)?;
        Ok(self.graph.eval_f64(&self.h, &mut inputs(x, &[], &[])))
    }

    /// J = ∂h/∂x at x.
    pub fn jacobian(&self, x: &[f64]) -> Result<DMatrix<f64>, MultiplierError> {
        self.point(x)?;
        let n = self.dim();
        let flat: Vec<Id> = self.jac.iter().flatten().copied().collect();
        let v = self.graph.eval_f64(&flat, &mut inputs(x, &[], &[]));
        Ok(DMatrix::from_row_slice(n, n, &v))
    }

    /// Ok when J is regular at x; otherwise [`MultiplierError::Singular`] naming the point and
    /// the column factors that vanish there.
    pub fn check(&self, x: &[f64]) -> Result<DMatrix<f64>, MultiplierError> {
        let j = self.jacobian(x)?;
        let svd = j.clone().svd(false, true);
        let sv = &svd.singular_values;
        let (lo, hi) = (sv.min(), sv.max());
        let rcond = if hi > 0.0 { lo / hi } else { 0.0 };
        if rcond > SINGULAR_RCOND {
            return Ok(j);
        }
        let k = sv.imin();
        let null: Vec<(String, f64)> = match &svd.v_t {
            Some(vt) => {
                let row = vt.row(k);
                // the sign that makes the largest component positive
                let big = row
                    .iter()
                    .fold(0.0f64, |m, &v| if v.abs() > m.abs() { v } else { m });
                let sign = if big < 0.0 { -1.0 } else { 1.0 };
                self.from
                    .iter()
                    .zip(row.iter())
                    .filter(|(_, v)| v.abs() > 1e-8)
                    .map(|(n, &v)| (n.clone(), sign * v))
                    .collect()
            }
            None => Vec::new(),
        };
        let factors = self.vanishing_factors(x);
        Err(MultiplierError::Singular {
            point: self.from.iter().cloned().zip(x.iter().copied()).collect(),
            factors,
            rcond,
            null,
        })
    }

    /// The subexpressions of J that vanish at x and whose vanishing alone makes J singular:
    /// J evaluated with the subexpression moved off zero (every occurrence, the rest of the
    /// point kept) is regular. Only the smallest such are kept (none containing another).
    fn vanishing_factors(&self, x: &[f64]) -> Vec<(String, f64)> {
        let flat: Vec<Id> = self.jac.iter().flatten().copied().collect();
        let order = self.graph.reachable(&flat);
        let values = eval_nodes(&self.graph, &order, x, None);
        let scale = x.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        let n = self.dim();
        let mut found: Vec<Id> = Vec::new();
        for &id in &order {
            if matches!(self.graph.node(id), Node::Num(_))
                || values[id.index()].abs() > VANISHING * scale
            {
                continue;
            }
            let moved = eval_nodes(&self.graph, &order, x, Some((id, 1e-3)));
            let j = DMatrix::from_iterator(n, n, flat.iter().map(|e| moved[e.index()])).transpose();
            let sv = j.singular_values();
            if sv.max() > 0.0 && sv.min() / sv.max() > SINGULAR_RCOND {
                found.push(id);
            }
        }
        let minimal: Vec<Id> = found
            .iter()
            .copied()
            .filter(|&c| {
                let inner = self.graph.reachable(&[c]);
                !found.iter().any(|&o| o != c && inner.contains(&o))
            })
            .collect();
        minimal
            .into_iter()
            .map(|c| (render(&self.graph, c, &self.from), values[c.index()]))
            .collect()
    }

    fn sized(&self, what: &str, v: &[f64]) -> Result<(), MultiplierError> {
        if v.len() != self.dim() {
            return Err(MultiplierError::Shape(format!(
                "{what} needs {} values, got {}",
                self.dim(),
                v.len()
            )));
        }
        Ok(())
    }

    /// λ = Jᵀσ: the x-frame's multipliers from the y-frame's (defined at every point).
    pub fn multipliers(&self, x: &[f64], sigma: &[f64]) -> Result<Vec<f64>, MultiplierError> {
        self.point(x)?;
        self.sized("σ", sigma)?;
        Ok(self
            .graph
            .eval_f64(&self.lambda, &mut inputs(x, sigma, &[])))
    }

    /// σ = J⁻ᵀλ: the y-frame's multipliers from the x-frame's (J regular at x).
    pub fn multipliers_inverse(
        &self,
        x: &[f64],
        lambda: &[f64],
    ) -> Result<Vec<f64>, MultiplierError> {
        self.sized("λ", lambda)?;
        let j = self.check(x)?;
        self.solve(j.transpose(), x, lambda)
    }

    /// ẋ = J⁻¹ẏ: the x-frame's rates from the y-frame's (J regular at x).
    pub fn state_rates(&self, x: &[f64], ydot: &[f64]) -> Result<Vec<f64>, MultiplierError> {
        self.sized("ẏ", ydot)?;
        let j = self.check(x)?;
        self.solve(j, x, ydot)
    }

    fn solve(&self, a: DMatrix<f64>, x: &[f64], b: &[f64]) -> Result<Vec<f64>, MultiplierError> {
        a.lu()
            .solve(&DVector::from_column_slice(b))
            .map(|v| v.iter().copied().collect())
            .ok_or_else(|| {
                // check() accepted J; an exactly singular LU here is still a singular point
                MultiplierError::Singular {
                    point: self.from.iter().cloned().zip(x.iter().copied()).collect(),
                    factors: Vec::new(),
                    rcond: 0.0,
                    null: Vec::new(),
                }
            })
    }

    /// λ̇ = Jᵀσ̇ + J̇ᵀσ along a motion with rates ẋ and σ̇ (the symbolic λ̇ evaluated).
    pub fn multiplier_rates(
        &self,
        x: &[f64],
        xdot: &[f64],
        sigma: &[f64],
        sigma_dot: &[f64],
    ) -> Result<Vec<f64>, MultiplierError> {
        self.point(x)?;
        self.sized("ẋ", xdot)?;
        self.sized("σ", sigma)?;
        self.sized("σ̇", sigma_dot)?;
        let sym: Vec<f64> = sigma.iter().chain(xdot).chain(sigma_dot).copied().collect();
        let rates = self
            .graph
            .eval_f64(&self.lambda_rate, &mut inputs(x, &sym, &[]));
        Ok(rates)
    }

    /// [`multiplier_rates`](Self::multiplier_rates) with, for each component, the magnitude of
    /// the terms summed to it (its rounding scale, [`Graph::eval_with_scale`]).
    pub fn multiplier_rates_scaled(
        &self,
        x: &[f64],
        xdot: &[f64],
        sigma: &[f64],
        sigma_dot: &[f64],
    ) -> Result<Vec<(f64, f64)>, MultiplierError> {
        self.multiplier_rates(x, xdot, sigma, sigma_dot)?;
        let sym: Vec<f64> = sigma.iter().chain(xdot).chain(sigma_dot).copied().collect();
        let scaled = self
            .lambda_rate
            .iter()
            .map(|&e| self.graph.eval_with_scale(e, &mut inputs(x, &sym, &[])))
            .collect();
        Ok(scaled)
    }

    /// The y-frame's Euler–Lagrange equations transformed to the x-frame at (x, λ):
    /// σ = J⁻ᵀλ, (ẏ, σ̇) from `y_frame` at (h(x), σ), ẋ = J⁻¹ẏ, λ̇ = Jᵀσ̇ + J̇ᵀσ.
    pub fn transform_equations(
        &self,
        y_frame: &EulerLagrange,
        params: &[f64],
        x: &[f64],
        lambda: &[f64],
    ) -> Result<(Vec<f64>, Vec<f64>), MultiplierError> {
        if y_frame.dim() != self.dim() {
            return Err(MultiplierError::Shape(format!(
                "the equations have {} coordinates, the coordinate change {}",
                y_frame.dim(),
                self.dim()
            )));
        }
        let sigma = self.multipliers_inverse(x, lambda)?;
        let y = self.apply(x)?;
        let (ydot, sigma_dot) = y_frame.eval(&y, &sigma, params);
        let xdot = self.state_rates(x, &ydot)?;
        let lambda_dot = self.multiplier_rates(x, &xdot, &sigma, &sigma_dot)?;
        Ok((xdot, lambda_dot))
    }
}

/// A frame's equations: the state equations ẋ = f(x, λ) (the controls already eliminated in
/// favour of the multipliers, as the paper does) and the Euler–Lagrange equations
/// λ̇ = −∂(λ·f)/∂x derived from them by the IR's differentiator.
///
/// Inputs: `State(i)` = xᵢ, `Symbol(i)` = λᵢ, `Param(k)` the problem's parameters.
#[derive(Clone)]
pub struct EulerLagrange {
    graph: Graph,
    f: Vec<Id>,
    adjoint: Vec<Id>,
}

impl EulerLagrange {
    /// The equations of ẋ = f(x, λ) given by `f` in `graph`.
    pub fn new(mut graph: Graph, f: Vec<Id>) -> EulerLagrange {
        let n = f.len();
        let terms: Vec<Id> = f
            .iter()
            .enumerate()
            .map(|(i, &fi)| {
                let l = graph.input(Input::Symbol(i as u32));
                graph.mul(&[l, fi])
            })
            .collect();
        let hamiltonian = graph.add(&terms);
        let adjoint = (0..n)
            .map(|i| {
                let mut memo = Default::default();
                let d = diff(&mut graph, hamiltonian, Input::State(i as u32), &mut memo);
                graph.neg(d)
            })
            .collect();
        EulerLagrange { graph, f, adjoint }
    }

    /// The dimension n.
    pub fn dim(&self) -> usize {
        self.f.len()
    }

    /// λ̇ᵢ = −∂(λ·f)/∂xᵢ as expressions.
    pub fn adjoint_exprs(&self) -> &[Id] {
        &self.adjoint
    }

    /// The expression IR of f and the adjoint equations.
    pub fn graph(&self) -> &Graph {
        &self.graph
    }

    /// (ẋ, λ̇) at (x, λ) with the parameters `params`.
    pub fn eval(&self, x: &[f64], lambda: &[f64], params: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let mut all = self.f.clone();
        all.extend(&self.adjoint);
        let v = self.graph.eval_f64(&all, &mut inputs(x, lambda, params));
        let n = self.dim();
        (v[..n].to_vec(), v[n..].to_vec())
    }

    /// [`eval`](Self::eval) with each component's rounding scale ([`Graph::eval_with_scale`]).
    #[allow(clippy::type_complexity)]
    pub fn eval_scaled(
        &self,
        x: &[f64],
        lambda: &[f64],
        params: &[f64],
    ) -> (Vec<(f64, f64)>, Vec<(f64, f64)>) {
        let one = |e: &Id| {
            self.graph
                .eval_with_scale(*e, &mut inputs(x, lambda, params))
        };
        (
            self.f.iter().map(one).collect(),
            self.adjoint.iter().map(one).collect(),
        )
    }
}
