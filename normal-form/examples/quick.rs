use lasalle_normal_form::models::Cr3bp;
use lasalle_normal_form::*;
fn main() {
    let mu: f64 = std::env::args().nth(1).map(|s| s.parse().unwrap()).unwrap_or(Cr3bp::EARTH_MOON);
    let order: usize = std::env::args().nth(2).map(|s| s.parse().unwrap()).unwrap_or(6);
    let h = Cr3bp { mu };
    let o = Options::with_order(order);
    match normalize(&h, &Point::Newton(h.l4().to_vec()), &o) {
        Ok(nf) => {
            println!("omega {:?} signs {:?}", nf.frequencies_linear(), nf.signs);
            for t in &nf.hamiltonian { println!("{:?} {:.16e} err {:?}", t.exponents, t.coeff.value, t.coeff.error); }
            println!("d4 {:?}", nf.d4);
            println!("diag {:?}", nf.diagnostics);
        }
        Err(e) => println!("error: {e}"),
    }
}
