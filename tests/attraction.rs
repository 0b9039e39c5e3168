//! Domains of attraction (src/stability/attraction.rs) on the damped Duffing equation of the
//! report's third paper, and LaSalle's invariance principle.

use lasalle::stability::attraction::{self, Options, PlanarSystem};
use lasalle::{Backend, LoadedModel, Parameters, MODEL_FILES};

fn duffing() -> LoadedModel {
    let text = MODEL_FILES.iter().find(|(s, _)| *s == "duffing").unwrap().1;
    LoadedModel::from_source("duffing.lsl", text, Backend::Jit).unwrap()
}

fn system(m: &LoadedModel) -> PlanarSystem {
    PlanarSystem::new(m.model(), m.params(), &m.point("origin").unwrap()).unwrap()
}

#[test]
fn scratch() {
    let m = duffing();
    let s = system(&m);
    let t = std::time::Instant::now();
    let a = s.analyse(&Options::default()).unwrap();
    println!("{:#?}", a);
    println!("{:?}", t.elapsed());
    let e = s.estimate_let("energy", a.radius, &Options::default()).unwrap();
    println!("{:#?} {:?}", e, t.elapsed());
}
