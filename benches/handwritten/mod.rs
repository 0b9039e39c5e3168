//! Hand-written feedback fields from the paper's closed forms — the baseline the generated
//! code is benchmarked against (`benches/feedback.rs`) and checked against
//! (`tests/experiments.rs`).
//!
//! Chang, Jiménez & Perlmutter 2016: the free rigid body (30a,b) = (13) − (19a,b) and the
//! Kepler problem (41) = (31) − Lemma 3.5, written the way one would by hand: plain `f64`
//! arrays, the intermediate quantities (RᵀR − I, ΔE, Δπ; ΔL, ΔA) computed once.

#![allow(dead_code, clippy::needless_range_loop)]

/// The rigid-body feedback field for 𝕀 = diag(`i`), state x = (R column-major, Ω):
///
/// ```text
/// Ṙ = RΩ̂ − k₀ R(RᵀR − I) − k₂ (π − π₀)(𝕀Ω)ᵀ
/// Ω̇ = 𝕀⁻¹((𝕀Ω) × Ω) − k₁ (E − E₀) 𝕀Ω − k₂ 𝕀Rᵀ(π − π₀)
/// ```
#[inline]
pub fn rigid_body(
    i: &[f64; 3],
    x: &[f64; 12],
    e0: f64,
    pi0: &[f64; 3],
    k: &[f64; 3],
    dx: &mut [f64; 12],
) {
    let r = |a: usize, b: usize| x[a + 3 * b];
    let w = [x[9], x[10], x[11]];
    let m = [i[0] * w[0], i[1] * w[1], i[2] * w[2]];
    // C = RᵀR − I (symmetric)
    let mut c = [[0.0; 3]; 3];
    for a in 0..3 {
        for b in a..3 {
            let s = r(0, a) * r(0, b) + r(1, a) * r(1, b) + r(2, a) * r(2, b);
            c[a][b] = if a == b { s - 1.0 } else { s };
            c[b][a] = c[a][b];
        }
    }
    let de = 0.5 * (m[0] * w[0] + m[1] * w[1] + m[2] * w[2]) - e0;
    // Δπ = R𝕀Ω − π₀
    let mut dpi = [0.0; 3];
    for a in 0..3 {
        dpi[a] = r(a, 0) * m[0] + r(a, 1) * m[1] + r(a, 2) * m[2] - pi0[a];
    }
    // RΩ̂ column by column: Ω̂e₀ = (0, ω₂, −ω₁), Ω̂e₁ = (−ω₂, 0, ω₀), Ω̂e₂ = (ω₁, −ω₀, 0)
    for a in 0..3 {
        let (r0, r1, r2) = (r(a, 0), r(a, 1), r(a, 2));
        let rw = [
            w[2] * r1 - w[1] * r2,
            w[0] * r2 - w[2] * r0,
            w[1] * r0 - w[0] * r1,
        ];
        for b in 0..3 {
            let rc = r0 * c[0][b] + r1 * c[1][b] + r2 * c[2][b];
            dx[a + 3 * b] = rw[b] - k[0] * rc - k[2] * dpi[a] * m[b];
        }
    }
    // 𝕀⁻¹((𝕀Ω) × Ω) − k₁ΔE 𝕀Ω − k₂ 𝕀RᵀΔπ
    let cross = [
        m[1] * w[2] - m[2] * w[1],
        m[2] * w[0] - m[0] * w[2],
        m[0] * w[1] - m[1] * w[0],
    ];
    for b in 0..3 {
        let rt_dpi = r(0, b) * dpi[0] + r(1, b) * dpi[1] + r(2, b) * dpi[2];
        dx[9 + b] = cross[b] / i[b] - k[1] * de * m[b] - k[2] * i[b] * rt_dpi;
    }
}

#[inline]
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// The Kepler feedback field (41), state (x, v), targets L₀ and A₀:
///
/// ```text
/// ẋ = v − k₁ v × ΔL − k₂ (v × (ΔA × v) − (μ/|x|) ΔA + (μ/|x|³) x (x·ΔA))
/// v̇ = −μ x/|x|³ − k₁ ΔL × x − k₂ ((x × v) × ΔA + x × (v × ΔA))
/// ```
#[inline]
pub fn kepler(
    mu: f64,
    s: &[f64; 6],
    l0: &[f64; 3],
    a0: &[f64; 3],
    k: &[f64; 2],
    ds: &mut [f64; 6],
) {
    let x = [s[0], s[1], s[2]];
    let v = [s[3], s[4], s[5]];
    let r2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2];
    let r = r2.sqrt();
    let mu_r = mu / r;
    let mu_r3 = mu_r / r2;
    let l = cross(x, v);
    let vl = cross(v, l);
    let dl = [l[0] - l0[0], l[1] - l0[1], l[2] - l0[2]];
    let da = [
        vl[0] - mu_r * x[0] - a0[0],
        vl[1] - mu_r * x[1] - a0[1],
        vl[2] - mu_r * x[2] - a0[2],
    ];
    let v_dl = cross(v, dl);
    let v_da_v = cross(v, cross(da, v));
    let x_da = x[0] * da[0] + x[1] * da[1] + x[2] * da[2];
    let dl_x = cross(dl, x);
    let l_da = cross(l, da);
    let x_v_da = cross(x, cross(v, da));
    for c in 0..3 {
        ds[c] = v[c] - k[0] * v_dl[c] - k[1] * (v_da_v[c] - mu_r * da[c] + mu_r3 * x[c] * x_da);
        ds[3 + c] = -mu_r3 * x[c] - k[0] * dl_x[c] - k[1] * (l_da[c] + x_v_da[c]);
    }
}
