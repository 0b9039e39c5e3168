//! The Hamiltonian route: `structure canonical(q, p)` and `structure lie_poisson_so3(P)` give the
//! textbook equations, and the Hamiltonian (and Casimir) come out as integrals.

use lasalle::models::{cr3bp::CR3BP, so3_type_i::So3TypeI};
use lasalle::{Field, Invariants};

fn close(a: &[f64], b: &[f64], rel: f64) -> bool {
    let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1e-300);
    a.iter().zip(b).all(|(x, y)| (x - y).abs() <= rel * scale)
}

#[test]
fn type_i_extremals_are_the_thesis_equations() {
    // Rodgerson (2009) (4.5)–(4.7): Ṗ1 = P2, Ṗ2 = −P1 + P1P3/c1, Ṗ3 = −P1P2/c1
    let m = So3TypeI::<f64>::default().prepare();
    let c1 = m.c1;
    let mut x = m.point_thesis();
    for k in 0..200 {
        let s = k as f64 * 0.37;
        x[0] = 4.0 * s.cos();
        x[1] = s.sin() - 0.5;
        x[2] = 1.0 + 0.3 * (2.0 * s).cos();
        let mut dx = [0.0; 12];
        m.field(&x, &mut dx);
        let (p1, p2, p3) = (x[0], x[1], x[2]);
        let want = [p2, -p1 + p1 * p3 / c1, -p1 * p2 / c1];
        assert!(close(&dx[..3], &want, 1e-14), "{:?} vs {want:?}", &dx[..3]);
    }
    let names: Vec<&str> = So3TypeI::<f64>::INVARIANTS
        .iter()
        .map(|f| f.slot.name)
        .collect();
    assert_eq!(names, ["H", "orthogonality", "Lambda", "casimir"]);
    let mut f = [0.0; 14];
    m.invariants(&m.point_thesis(), &mut f);
    assert_eq!(f[0], 16.0 / 4.0 + 1.0); // H = P1²/(2c1) + P3 = 5
    assert_eq!(f[10..13], [4.0, 0.0, 1.0]); // Λ = g P = P(0) at g = I
    assert_eq!(f[13], 17.0); // |P|² = 17
}

#[test]
fn cr3bp_canonical_equations_and_l4_equilibrium() {
    let m = CR3BP::<f64>::default().prepare();
    let mu = m.mu;
    for k in 0..200 {
        let s = k as f64 * 0.61;
        let x = [
            0.3 + s.cos(),
            0.8 * s.sin(),
            -0.7 + 0.1 * s,
            0.4 * (3.0 * s).cos(),
        ];
        let (qx, qy, px, py) = (x[0], x[1], x[2], x[3]);
        let r1 = ((qx + mu).powi(2) + qy * qy).sqrt();
        let r2 = ((qx - 1.0 + mu).powi(2) + qy * qy).sqrt();
        let want = [
            px + qy,
            py - qx,
            py - (1.0 - mu) * (qx + mu) / r1.powi(3) - mu * (qx - 1.0 + mu) / r2.powi(3),
            -px - (1.0 - mu) * qy / r1.powi(3) - mu * qy / r2.powi(3),
        ];
        let mut dx = [0.0; 4];
        m.field(&x, &mut dx);
        assert!(close(&dx, &want, 1e-13), "{dx:?} vs {want:?}");
    }
    let mut dx = [1.0; 4];
    m.field(&m.point_l4(), &mut dx);
    assert!(
        dx.iter().all(|d| d.abs() < 1e-15),
        "L4 is an equilibrium: {dx:?}"
    );
}
