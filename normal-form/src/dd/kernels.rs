//! The series product kernels in double-double: `out[lk[ka[i] + kb[j]]] += a[i]·b[j]` over
//! all pairs (see `Coeff::mul_acc_kernel`), with one renormalisation per accumulation instead
//! of a full dd addition and multiplication. Three variants, chosen at run time: plain (Dekker
//! products), scalar FMA, and AVX2 (two complex products at a time); the FMA and AVX2 ones are
//! bit-for-bit equal.

use super::{quick_two_sum, two_sum, Dd};
use crate::complex::Complex;
use crate::scalar::generic_kernel;

/// The real kernel, the fastest variant this CPU runs.
pub(super) fn real(out: &mut [Dd], a: &[Dd], ka: &[u32], b: &[Dd], kb: &[u32], lk: &[u32]) {
    // SAFETY: the fma variant runs only when the CPU has FMA, the AVX2 one only with AVX2 and
    // FMA; all rely on the key invariant documented on `Coeff::mul_acc_kernel`.
    unsafe {
        #[cfg(target_arch = "x86_64")]
        if has_avx2_fma() {
            return avx::real_kernel(out, a, ka, b, kb, lk);
        }
        #[cfg(target_arch = "x86_64")]
        if has_fma() {
            return real_kernel_fma(out, a, ka, b, kb, lk);
        }
        real_kernel_plain(out, a, ka, b, kb, lk)
    }
}

/// The complex kernel, the fastest variant this CPU runs.
pub(super) fn complex(
    out: &mut [Complex<Dd>],
    a: &[Complex<Dd>],
    ka: &[u32],
    b: &[Complex<Dd>],
    kb: &[u32],
    lk: &[u32],
) {
    // SAFETY: as for `real`.
    unsafe {
        #[cfg(target_arch = "x86_64")]
        if has_avx2_fma() {
            return avx::complex_kernel(out, a, ka, b, kb, lk);
        }
        #[cfg(target_arch = "x86_64")]
        if has_fma() {
            return complex_kernel_fma(out, a, ka, b, kb, lk);
        }
        complex_kernel_plain(out, a, ka, b, kb, lk)
    }
}

/// `c + a·b + x·y` with one renormalisation: the two exact products (TwoProd) and the two
/// exact sums of the leading parts, all error terms gathered in the tail. The error is a few
/// 2⁻¹⁰⁶ relative to |c| + |a·b| + |x·y| (as for any accumulation).
#[inline(always)]
fn acc2(c: Dd, a: Dd, b: Dd, x: Dd, y: Dd, tp: impl Fn(f64, f64) -> (f64, f64)) -> Dd {
    let (p, e1) = tp(a.hi, b.hi);
    let (q, e2) = tp(x.hi, y.hi);
    let cross = (a.hi * b.lo + a.lo * b.hi) + (x.hi * y.lo + x.lo * y.hi);
    let (s, f) = two_sum(c.hi, p);
    let (s, g) = two_sum(s, q);
    let lo = c.lo + ((e1 + e2) + (cross + (f + g)));
    let (hi, lo) = quick_two_sum(s, lo);
    Dd { hi, lo }
}

/// [`acc2`] with FMA: the cross terms `a.hi·b.lo + a.lo·b.hi + x.hi·y.lo + x.lo·y.hi` by
/// three fused multiply-adds (the lane arithmetic of the AVX2 kernel, bit for bit).
#[inline(always)]
fn acc2_fma(c: Dd, a: Dd, b: Dd, x: Dd, y: Dd) -> Dd {
    let (p, e1) = two_prod_fma(a.hi, b.hi);
    let (q, e2) = two_prod_fma(x.hi, y.hi);
    let cross =
        a.hi.mul_add(b.lo, a.lo.mul_add(b.hi, x.hi.mul_add(y.lo, x.lo * y.hi)));
    let (s, f) = two_sum(c.hi, p);
    let (s, g) = two_sum(s, q);
    let lo = c.lo + ((e1 + e2) + (cross + (f + g)));
    let (hi, lo) = quick_two_sum(s, lo);
    Dd { hi, lo }
}

/// `c + a·b`, same scheme.
#[inline(always)]
fn acc1(c: Dd, a: Dd, b: Dd, tp: impl Fn(f64, f64) -> (f64, f64)) -> Dd {
    let (p, e1) = tp(a.hi, b.hi);
    let cross = a.hi * b.lo + a.lo * b.hi;
    let (s, f) = two_sum(c.hi, p);
    let lo = c.lo + (e1 + (cross + f));
    let (hi, lo) = quick_two_sum(s, lo);
    Dd { hi, lo }
}

/// [`acc1`] with FMA (the cross term `a.hi·b.lo + a.lo·b.hi` fused; the lane arithmetic of
/// the AVX2 kernel, bit for bit).
#[inline(always)]
fn acc1_fma(c: Dd, a: Dd, b: Dd) -> Dd {
    let (p, e1) = two_prod_fma(a.hi, b.hi);
    let cross = a.hi.mul_add(b.lo, a.lo * b.hi);
    let (s, f) = two_sum(c.hi, p);
    let lo = c.lo + (e1 + (cross + f));
    let (hi, lo) = quick_two_sum(s, lo);
    Dd { hi, lo }
}

#[inline(always)]
fn two_prod_dekker(a: f64, b: f64) -> (f64, f64) {
    const SPLITTER: f64 = 134_217_729.0; // 2^27 + 1
    let p = a * b;
    let t = SPLITTER * a;
    let ah = t - (t - a);
    let al = a - ah;
    let t = SPLITTER * b;
    let bh = t - (t - b);
    let bl = b - bh;
    (p, ((ah * bh - p) + ah * bl + al * bh) + al * bl)
}

#[inline(always)]
fn two_prod_fma(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    (p, a.mul_add(b, -p))
}

macro_rules! kernels {
    ($complex:ident, $real:ident, $acc1:expr, $acc2:expr $(, #[$attr:meta])?) => {
        $(#[$attr])?
        unsafe fn $complex(out: &mut [Complex<Dd>], a: &[Complex<Dd>], ka: &[u32], b: &[Complex<Dd>], kb: &[u32], lk: &[u32]) {
            generic_kernel(out, a, ka, b, kb, lk, |o, x, y| {
                o.re = $acc2(o.re, x.re, y.re, -x.im, y.im);
                o.im = $acc2(o.im, x.re, y.im, x.im, y.re);
            });
        }
        $(#[$attr])?
        unsafe fn $real(out: &mut [Dd], a: &[Dd], ka: &[u32], b: &[Dd], kb: &[u32], lk: &[u32]) {
            generic_kernel(out, a, ka, b, kb, lk, |o, x, y| *o = $acc1(*o, x, y));
        }
    };
}
kernels!(
    complex_kernel_plain,
    real_kernel_plain,
    |c, a, b| acc1(c, a, b, two_prod_dekker),
    |c, a, b, x, y| acc2(c, a, b, x, y, two_prod_dekker)
);
#[cfg(target_arch = "x86_64")]
kernels!(complex_kernel_fma, real_kernel_fma, acc1_fma, acc2_fma, #[target_feature(enable = "fma")]);

#[inline]
fn has_fma() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

#[inline]
fn has_avx2_fma() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The complex double-double product kernel in AVX2: two products `out[·] += a[i]·b[j]`,
/// `a[i]·b[j+1]` at a time, the four lanes holding (re, im) of both. Per lane it is exactly
/// the scalar `acc2` (two TwoProds, the cross terms by FMA, two TwoSums, one renormalisation),
/// so the results are bit-for-bit those of `complex_kernel_fma` ([`acc2_fma`]).
#[cfg(target_arch = "x86_64")]
mod avx {
    use super::{acc1_fma, acc2_fma, Complex, Dd};
    use std::arch::x86_64::*;

    /// (hi, lo) of two complex dd at `p` and `q` as lanes [re(p), im(p), re(q), im(q)].
    #[inline(always)]
    unsafe fn load2(p: *const f64, q: *const f64) -> (__m256d, __m256d) {
        let u = _mm256_loadu_pd(p); // [rh, rl, ih, il] of p
        let v = _mm256_loadu_pd(q);
        let t0 = _mm256_permute2f128_pd::<0x20>(u, v); // [rh_p, rl_p, rh_q, rl_q]
        let t1 = _mm256_permute2f128_pd::<0x31>(u, v); // [ih_p, il_p, ih_q, il_q]
        (_mm256_unpacklo_pd(t0, t1), _mm256_unpackhi_pd(t0, t1))
    }

    /// Inverse of [`load2`].
    #[inline(always)]
    unsafe fn store2(p: *mut f64, q: *mut f64, hi: __m256d, lo: __m256d) {
        let t0 = _mm256_unpacklo_pd(hi, lo); // [rh_p, rl_p, rh_q, rl_q]
        let t1 = _mm256_unpackhi_pd(hi, lo); // [ih_p, il_p, ih_q, il_q]
        _mm256_storeu_pd(p, _mm256_permute2f128_pd::<0x20>(t0, t1));
        _mm256_storeu_pd(q, _mm256_permute2f128_pd::<0x31>(t0, t1));
    }

    /// The real double-double product kernel, four products `a[i]·b[j..j+4]` at a time (lanes
    /// in the order j, j+2, j+1, j+3 of `unpacklo/hi`); per lane exactly [`acc1_fma`].
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn real_kernel(
        out: &mut [Dd],
        a: &[Dd],
        ka: &[u32],
        b: &[Dd],
        kb: &[u32],
        lk: &[u32],
    ) {
        assert!(ka.len() == a.len() && kb.len() == b.len());
        let o = out.as_mut_ptr() as *mut f64;
        let bp = b.as_ptr() as *const f64;
        let quads = b.len() / 4;
        for (i, &x) in a.iter().enumerate() {
            if x.hi == 0.0 {
                continue;
            }
            let base = ka[i];
            let ah = _mm256_set1_pd(x.hi);
            let al = _mm256_set1_pd(x.lo);
            for jq in 0..quads {
                let j = 4 * jq;
                let mut idx = [0usize; 4];
                for (m, id) in idx.iter_mut().enumerate() {
                    let k = (base + *kb.get_unchecked(j + m)) as usize;
                    debug_assert!(k < lk.len());
                    *id = *lk.get_unchecked(k) as usize;
                    debug_assert!(*id < out.len());
                }
                let u = _mm256_loadu_pd(bp.add(2 * j)); // [h0, l0, h1, l1]
                let v = _mm256_loadu_pd(bp.add(2 * j + 4)); // [h2, l2, h3, l3]
                let bh = _mm256_unpacklo_pd(u, v); // [h0, h2, h1, h3]
                let bl = _mm256_unpackhi_pd(u, v);
                let p = [
                    o.add(2 * idx[0]),
                    o.add(2 * idx[1]),
                    o.add(2 * idx[2]),
                    o.add(2 * idx[3]),
                ];
                let cu = _mm256_insertf128_pd::<1>(
                    _mm256_castpd128_pd256(_mm_loadu_pd(p[0])),
                    _mm_loadu_pd(p[1]),
                );
                let cv = _mm256_insertf128_pd::<1>(
                    _mm256_castpd128_pd256(_mm_loadu_pd(p[2])),
                    _mm_loadu_pd(p[3]),
                );
                let ch = _mm256_unpacklo_pd(cu, cv);
                let cl = _mm256_unpackhi_pd(cu, cv);
                let prod = _mm256_mul_pd(ah, bh);
                let e1 = _mm256_fmsub_pd(ah, bh, prod);
                let cross = _mm256_fmadd_pd(ah, bl, _mm256_mul_pd(al, bh));
                let s = _mm256_add_pd(ch, prod);
                let bb = _mm256_sub_pd(s, ch);
                let f = _mm256_add_pd(
                    _mm256_sub_pd(ch, _mm256_sub_pd(s, bb)),
                    _mm256_sub_pd(prod, bb),
                );
                let lo = _mm256_add_pd(cl, _mm256_add_pd(e1, _mm256_add_pd(cross, f)));
                let hi = _mm256_add_pd(s, lo);
                let lo = _mm256_sub_pd(lo, _mm256_sub_pd(hi, s));
                let ru = _mm256_unpacklo_pd(hi, lo); // [h0, l0, h1, l1]
                let rv = _mm256_unpackhi_pd(hi, lo); // [h2, l2, h3, l3]
                _mm_storeu_pd(p[0], _mm256_castpd256_pd128(ru));
                _mm_storeu_pd(p[1], _mm256_extractf128_pd::<1>(ru));
                _mm_storeu_pd(p[2], _mm256_castpd256_pd128(rv));
                _mm_storeu_pd(p[3], _mm256_extractf128_pd::<1>(rv));
            }
            for j in 4 * quads..b.len() {
                let idx = *lk.get_unchecked((base + kb[j]) as usize) as usize;
                let c = out.get_unchecked_mut(idx);
                *c = acc1_fma(*c, x, b[j]);
            }
        }
    }

    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn complex_kernel(
        out: &mut [Complex<Dd>],
        a: &[Complex<Dd>],
        ka: &[u32],
        b: &[Complex<Dd>],
        kb: &[u32],
        lk: &[u32],
    ) {
        assert!(ka.len() == a.len() && kb.len() == b.len());
        let o = out.as_mut_ptr() as *mut f64;
        let bp = b.as_ptr() as *const f64;
        let pairs = b.len() / 2;
        for (i, &x) in a.iter().enumerate() {
            if x.re.hi == 0.0 && x.im.hi == 0.0 {
                continue;
            }
            let base = ka[i];
            // re lane: xr·yr + (−xi)·yi ; im lane: xr·yi + xi·yr
            let ah = _mm256_set1_pd(x.re.hi);
            let al = _mm256_set1_pd(x.re.lo);
            let xh = _mm256_setr_pd(-x.im.hi, x.im.hi, -x.im.hi, x.im.hi);
            let xl = _mm256_setr_pd(-x.im.lo, x.im.lo, -x.im.lo, x.im.lo);
            for jj in 0..pairs {
                let j = 2 * jj;
                let k0 = (base + *kb.get_unchecked(j)) as usize;
                let k1 = (base + *kb.get_unchecked(j + 1)) as usize;
                debug_assert!(k0 < lk.len() && k1 < lk.len());
                let i0 = *lk.get_unchecked(k0) as usize;
                let i1 = *lk.get_unchecked(k1) as usize;
                debug_assert!(i0 < out.len() && i1 < out.len() && i0 != i1);
                let (bh, bl) = load2(bp.add(4 * j), bp.add(4 * j + 4));
                let yh = _mm256_permute_pd::<0b0101>(bh);
                let yl = _mm256_permute_pd::<0b0101>(bl);
                let (p0, p1) = (o.add(4 * i0), o.add(4 * i1));
                let (ch, cl) = load2(p0, p1);
                let p = _mm256_mul_pd(ah, bh);
                let e1 = _mm256_fmsub_pd(ah, bh, p);
                let q = _mm256_mul_pd(xh, yh);
                let e2 = _mm256_fmsub_pd(xh, yh, q);
                let cross = _mm256_fmadd_pd(
                    ah,
                    bl,
                    _mm256_fmadd_pd(al, bh, _mm256_fmadd_pd(xh, yl, _mm256_mul_pd(xl, yh))),
                );
                // (s, f) = TwoSum(c.hi, p)
                let s = _mm256_add_pd(ch, p);
                let bb = _mm256_sub_pd(s, ch);
                let f = _mm256_add_pd(
                    _mm256_sub_pd(ch, _mm256_sub_pd(s, bb)),
                    _mm256_sub_pd(p, bb),
                );
                // (s2, g) = TwoSum(s, q)
                let s2 = _mm256_add_pd(s, q);
                let bb = _mm256_sub_pd(s2, s);
                let g = _mm256_add_pd(
                    _mm256_sub_pd(s, _mm256_sub_pd(s2, bb)),
                    _mm256_sub_pd(q, bb),
                );
                let lo = _mm256_add_pd(
                    cl,
                    _mm256_add_pd(
                        _mm256_add_pd(e1, e2),
                        _mm256_add_pd(cross, _mm256_add_pd(f, g)),
                    ),
                );
                // QuickTwoSum(s2, lo)
                let hi = _mm256_add_pd(s2, lo);
                let lo = _mm256_sub_pd(lo, _mm256_sub_pd(hi, s2));
                store2(p0, p1, hi, lo);
            }
            if b.len() % 2 == 1 {
                let j = b.len() - 1;
                let idx = *lk.get_unchecked((base + kb[j]) as usize) as usize;
                let y = b[j];
                let c = out.get_unchecked_mut(idx);
                c.re = acc2_fma(c.re, x.re, y.re, -x.im, y.im);
                c.im = acc2_fma(c.im, x.re, y.im, x.im, y.re);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scalar::Real;

    /// The kernels agree bit for bit (AVX2 vs scalar FMA) and with plain dd arithmetic to
    /// ~1e-31.
    #[test]
    fn complex_kernels_agree() {
        use crate::MonomialTable;
        let t = MonomialTable::new(4, 9);
        let mut rng = lasalle_testkit::Rng::new(12345);
        let mut rnd = || {
            let x = rng.uniform(-0.5, 0.5);
            Dd::new(x) + Dd::new(x * 1e-17)
        };
        let (da, db) = (4, 5);
        let a: Vec<Complex<Dd>> = (0..t.count(da))
            .map(|_| Complex::new(rnd(), rnd()))
            .collect();
        let b: Vec<Complex<Dd>> = (0..t.count(db))
            .map(|_| Complex::new(rnd(), rnd()))
            .collect();
        let (ka, kb, lk) = (
            &t.degree(da).keys,
            &t.degree(db).keys,
            &t.degree(da + db).lookup,
        );
        let zero = vec![Complex::new(Dd::new(0.0), Dd::new(0.0)); t.count(da + db)];
        let mut reference = zero.clone();
        generic_kernel(&mut reference, &a, ka, &b, kb, lk, |o, x, y| *o += x * y);
        let mut plain = zero.clone();
        unsafe { complex_kernel_plain(&mut plain, &a, ka, &b, kb, lk) };
        let close = |u: &[Complex<Dd>]| {
            u.iter().zip(&reference).all(|(x, y)| {
                (x.re - y.re).to_f64().abs() < 1e-30 && (x.im - y.im).to_f64().abs() < 1e-30
            })
        };
        assert!(close(&plain));
        #[cfg(target_arch = "x86_64")]
        if has_avx2_fma() {
            let mut f = zero.clone();
            unsafe { complex_kernel_fma(&mut f, &a, ka, &b, kb, lk) };
            let mut v = zero.clone();
            unsafe { avx::complex_kernel(&mut v, &a, ka, &b, kb, lk) };
            assert!(close(&f));
            assert_eq!(f, v);
            // odd length of b
            let (mut f, mut v) = (zero.clone(), zero.clone());
            let n = b.len() - 1;
            unsafe { complex_kernel_fma(&mut f, &a, ka, &b[..n], &kb[..n], lk) };
            unsafe { avx::complex_kernel(&mut v, &a, ka, &b[..n], &kb[..n], lk) };
            assert_eq!(f, v);
        }
    }

    #[test]
    fn real_kernels_agree() {
        use crate::MonomialTable;
        let t = MonomialTable::new(4, 11);
        let mut rng = lasalle_testkit::Rng::new(987);
        let mut rnd = || {
            let x = rng.uniform(-0.5, 0.5);
            Dd::new(x) + Dd::new(x * 1e-17)
        };
        for (da, db) in [(3, 5), (4, 6), (1, 7), (2, 2)] {
            let a: Vec<Dd> = (0..t.count(da)).map(|_| rnd()).collect();
            let b: Vec<Dd> = (0..t.count(db)).map(|_| rnd()).collect();
            let (ka, kb, lk) = (
                &t.degree(da).keys,
                &t.degree(db).keys,
                &t.degree(da + db).lookup,
            );
            let zero = vec![Dd::new(0.0); t.count(da + db)];
            let mut reference = zero.clone();
            generic_kernel(&mut reference, &a, ka, &b, kb, lk, |o, x, y| *o += x * y);
            let mut plain = zero.clone();
            unsafe { real_kernel_plain(&mut plain, &a, ka, &b, kb, lk) };
            assert!(plain
                .iter()
                .zip(&reference)
                .all(|(x, y)| (*x - *y).to_f64().abs() < 1e-30));
            #[cfg(target_arch = "x86_64")]
            if has_avx2_fma() {
                let (mut f, mut v) = (zero.clone(), zero.clone());
                unsafe { real_kernel_fma(&mut f, &a, ka, &b, kb, lk) };
                unsafe { avx::real_kernel(&mut v, &a, ka, &b, kb, lk) };
                assert_eq!(f, v);
            }
        }
    }
}
