//! Bracketing root finding: Brent's method (Brent 1973, *Algorithms for Minimization without
//! Derivatives*, ch. 4, `zeroin`), and golden-section minimisation for touches.

/// A zero of `f` in the bracket [a, b] where `fa = f(a)` and `fb = f(b)` have opposite signs
/// (or one is 0): Brent's combination of bisection, secant and inverse quadratic
/// interpolation, to a bracket of a few ulps of the root (tolerance 2 ε |t| + `xtol`/2 with
/// `xtol` ≥ 0). Never leaves [a, b]; at most `4 + 2·log₂((b − a)/ulp)` evaluations.
pub fn brent(mut f: impl FnMut(f64) -> f64, a: f64, b: f64, fa: f64, fb: f64, xtol: f64) -> f64 {
    if fa == 0.0 {
        return a;
    }
    if fb == 0.0 {
        return b;
    }
    let (mut a, mut b, mut fa, mut fb) = (a, b, fa, fb);
    let (mut c, mut fc) = (b, fb);
    let (mut d, mut e) = (b - a, b - a);
    for _ in 0..200 {
        if (fb > 0.0) == (fc > 0.0) {
            c = a;
            fc = fa;
            d = b - a;
            e = d;
        }
        if fc.abs() < fb.abs() {
            a = b;
            b = c;
            c = a;
            fa = fb;
            fb = fc;
            fc = fa;
        }
        let tol1 = 2.0 * f64::EPSILON * b.abs() + 0.5 * xtol;
        let xm = 0.5 * (c - b);
        if xm.abs() <= tol1 || fb == 0.0 {
            return b;
        }
        if e.abs() >= tol1 && fa.abs() > fb.abs() {
            let s = fb / fa;
            let (mut p, mut q);
            if a == c {
                p = 2.0 * xm * s;
                q = 1.0 - s;
            } else {
                let qq = fa / fc;
                let r = fb / fc;
                p = s * (2.0 * xm * qq * (qq - r) - (b - a) * (r - 1.0));
                q = (qq - 1.0) * (r - 1.0) * (s - 1.0);
            }
            if p > 0.0 {
                q = -q;
            } else {
                p = -p;
            }
            if 2.0 * p < (3.0 * xm * q - (tol1 * q).abs()).min((e * q).abs()) {
                e = d;
                d = p / q;
            } else {
                d = xm;
                e = d;
            }
        } else {
            d = xm;
            e = d;
        }
        a = b;
        fa = fb;
        b += if d.abs() > tol1 { d } else { tol1.copysign(xm) };
        fb = f(b);
        if fb.is_nan() {
            return b;
        }
    }
    b
}

/// The point of [a, b] where `f` is smallest, by golden-section search to a relative width of
/// about √ε (the best a minimum can be located from function values), with its value.
pub fn golden_min(mut f: impl FnMut(f64) -> f64, a: f64, b: f64) -> (f64, f64) {
    const R: f64 = 0.618_033_988_749_894_8; // (√5 − 1)/2
    let (mut a, mut b) = (a, b);
    let mut c = b - R * (b - a);
    let mut d = a + R * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    let tol = f64::EPSILON.sqrt() * (a.abs() + b.abs()).max(f64::MIN_POSITIVE);
    for _ in 0..100 {
        if (b - a).abs() <= tol {
            break;
        }
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - R * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + R * (b - a);
            fd = f(d);
        }
    }
    if fc < fd {
        (c, fc)
    } else {
        (d, fd)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// cos has its zero at π/2; Brent finds it to within 2 ulps, from a wide bracket.
    #[test]
    fn brent_finds_pi_over_two_to_ulps() {
        let mut calls = 0;
        let t = brent(
            |t| {
                calls += 1;
                t.cos()
            },
            0.0,
            3.0,
            1.0,
            3f64.cos(),
            0.0,
        );
        let half_pi = std::f64::consts::FRAC_PI_2;
        assert!((t - half_pi).abs() <= 2.0 * f64::EPSILON * half_pi, "{t}");
        assert!(calls < 20, "{calls} evaluations");
    }

    /// A root with a flat neighbourhood (x³) and one at an end of the bracket.
    #[test]
    fn brent_on_a_triple_root_and_at_an_end() {
        let t = brent(|t| (t - 0.3).powi(3), 0.0, 1.0, -0.027, 0.343, 0.0);
        assert!((t - 0.3).abs() < 1e-5, "{t}");
        assert_eq!(brent(|t| t, 0.0, 1.0, 0.0, 1.0, 0.0), 0.0);
    }

    #[test]
    fn golden_section_finds_a_parabolas_vertex() {
        let (t, v) = golden_min(|t| (t - 0.7).powi(2) + 2.0, 0.0, 1.0);
        assert!((t - 0.7).abs() < 1e-7 && (v - 2.0).abs() < 1e-14, "{t} {v}");
    }
}
