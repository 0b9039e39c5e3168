//! Symbolic proofs that an expression vanishes identically.
//!
//! Expansion multiplies out products of sums and collects like terms; if the result is the
//! number 0, the expression is zero. Square roots of a sum s (as in r = |x| = √(x·x)) defeat
//! plain expansion, because r² and x·x are different terms. So, for an expression whose
//! radicals all have one base s, every power s^(p/q) (q ∈ {1, 2}) becomes ρ^(2p/q) for a fresh
//! symbol ρ; the Laurent polynomial in ρ is multiplied by the power of ρ (> 0) that clears its
//! denominators, and ρ² is replaced by s: the result P₀ + P₁ρ expands to 0 exactly when the
//! expression vanishes wherever s > 0. This proves the Laplace–Runge–Lenz vector conserved.

use crate::ir::{Graph, Id, Input, Node, Rational};

/// The auxiliary symbol ρ = √s.
const RHO: Input = Input::Symbol(0);

/// `true` if `root` is proved identically zero (where its radicals are defined); `false`
/// means "not proved", not "non-zero". Work is bounded by the expansion budget `limit`.
pub fn vanishes(g: &mut Graph, root: Id, limit: usize) -> bool {
    let Some(e) = g.expand(root, limit) else {
        return false;
    };
    if g.as_num(e) == Some(0.0) {
        return true;
    }
    let mut bases: Vec<Id> = g
        .reachable(&[e])
        .into_iter()
        .filter_map(|id| match g.node(id) {
            Node::Pow(b, r) if r.den == 2 => Some(*b),
            _ => None,
        })
        .collect();
    bases.dedup();
    let [s] = bases[..] else { return false };
    let rho = g.input(RHO);
    // s^(p/q) → ρ^(2p/q)
    let with_rho = g.rebuild(&[e], |g, node| match *node {
        Node::Pow(b, r) if b == s && 2 % r.den == 0 => {
            Some(g.pow(rho, Rational::int(r.num * 2 / r.den)))
        }
        _ => None,
    })[0];
    let Some(laurent) = g.expand(with_rho, limit) else {
        return false;
    };
    // Clear negative powers of ρ (ρ > 0), then reduce ρⁿ = s^(n div 2) ρ^(n mod 2).
    let lowest = g
        .reachable(&[laurent])
        .into_iter()
        .filter_map(|id| match g.node(id) {
            Node::Pow(b, r) if *b == rho => Some(r.num),
            _ => None,
        })
        .min()
        .unwrap_or(0)
        .min(0);
    let clear = g.pow(rho, Rational::int(-lowest));
    let product = g.mul(&[clear, laurent]);
    let Some(polynomial) = g.expand(product, limit) else {
        return false;
    };
    let reduced = g.rebuild(&[polynomial], |g, node| match *node {
        Node::Pow(b, r) if b == rho => {
            let (sq, odd) = (
                g.pow(s, Rational::int(r.num / 2)),
                g.pow(rho, Rational::int(r.num % 2)),
            );
            Some(g.mul(&[sq, odd]))
        }
        _ => None,
    })[0];
    g.expand(reduced, limit)
        .is_some_and(|z| g.as_num(z) == Some(0.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Σ v₀xᵢ²/r³ − v₀/r = 0 needs r² = x₀² + x₁² + x₂², which expansion alone cannot use.
    #[test]
    fn radicals_of_one_sum_are_reduced_with_rho_squared_equal_to_s() {
        let mut g = Graph::new();
        let x: Vec<Id> = (0..3).map(|i| g.input(Input::State(i))).collect();
        let v: Vec<Id> = (3..6).map(|i| g.input(Input::State(i))).collect();
        let sq: Vec<Id> = x.iter().map(|&xi| g.pow(xi, Rational::int(2))).collect();
        let s = g.add(&sq);
        let xv_terms: Vec<Id> = (0..3).map(|i| g.mul(&[x[i], v[i]])).collect();
        let xv = g.add(&xv_terms);
        let r_1 = g.pow(s, Rational::new(-1, 2));
        let r_3 = g.pow(s, Rational::new(-3, 2));
        let terms: Vec<Id> = sq.iter().map(|&xi2| g.mul(&[v[0], xi2, r_3])).collect();
        let a = g.add(&terms);
        let b = g.mul(&[v[0], r_1]);
        let zero = g.sub(a, b);
        assert!(
            g.expand(zero, 1000)
                .is_some_and(|z| g.as_num(z) != Some(0.0)),
            "plain expansion cannot see it"
        );
        assert!(vanishes(&mut g, zero, 1000));
        // and a non-zero expression is not "proved"
        let c = g.mul(&[x[0], xv, r_3]);
        assert!(!vanishes(&mut g, c, 1000));
    }
}
