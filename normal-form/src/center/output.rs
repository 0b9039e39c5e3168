//! Dumps of a [`CenterManifold`]: a table, JSON, CSV, Rust code and a DSL model of the
//! reduced Hamiltonian (which lasalle's JIT runs).

use super::CenterManifold;
use crate::normal_form::{PolyMap, Value};
use lasalle_runtime::Csv;
use std::fmt::Write;

fn value_str(v: &Value) -> String {
    if v.lo != 0.0 {
        format!("{:.17e} {:+.3e}", v.value, v.lo)
    } else {
        format!("{:.17e}", v.value)
    }
}

fn monomial(vars: &[String], e: &[u32]) -> String {
    let parts: Vec<String> = vars
        .iter()
        .zip(e)
        .filter(|(_, &k)| k > 0)
        .map(|(v, &k)| {
            if k == 1 {
                v.clone()
            } else {
                format!("{v}^{k}")
            }
        })
        .collect();
    if parts.is_empty() {
        "1".into()
    } else {
        parts.join(" ")
    }
}

fn exps(e: &[u32]) -> String {
    e.iter()
        .map(|x| x.to_string())
        .collect::<Vec<_>>()
        .join(" ")
}

fn lit(x: f64) -> String {
    let s = format!("{x:?}");
    if s.contains('.') || s.contains('e') || s.contains("inf") || s.contains("NaN") {
        s
    } else {
        format!("{s}.0")
    }
}

impl CenterManifold {
    /// Names of the reduced coordinates: Q2…Qn, P2…Pn.
    pub fn reduced_names(&self) -> Vec<String> {
        (2..=self.n_dof)
            .map(|k| format!("Q{k}"))
            .chain((2..=self.n_dof).map(|k| format!("P{k}")))
            .collect()
    }

    /// Names of the actions: I1 (hyperbolic, Q1'P1'), I2…In.
    pub fn action_names(&self) -> Vec<String> {
        (1..=self.n_dof).map(|k| format!("I{k}")).collect()
    }

    /// Names of the centre frequencies: omega_p (and omega_v) for the three-body models,
    /// omega2… otherwise.
    pub fn omega_names(&self) -> Vec<String> {
        if self.gamma.is_some() {
            ["omega_p", "omega_v"][..self.n_dof - 1]
                .iter()
                .map(|s| s.to_string())
                .collect()
        } else {
            (2..=self.n_dof).map(|k| format!("omega{k}")).collect()
        }
    }

    /// Everything as pretty JSON (the coordinate maps are left out: see [`CenterManifold::to_rust`]).
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("serialisable")
    }

    /// One row per number: `section,name,exponents,degree,value,lo`. Sections: `equilibrium`,
    /// `energy`, `gamma`, `lambda`, `omega` (the sign σ in the exponents column), `reduced`
    /// (exponents of Q₂…Q_n, P₂…P_n; nonzero terms), `birkhoff` (exponents of I₁…I_n),
    /// `timing` (seconds).
    pub fn to_csv(&self) -> String {
        let mut s = Csv::new(Vec::new());
        let io = "writing to memory does not fail";
        s.record(["section", "name", "exponents", "degree", "value", "lo"])
            .expect(io);
        let row = |s: &mut Csv<Vec<u8>>, sec: &str, name: &str, e: &str, deg: String, v: &Value| {
            let (value, lo) = (format!("{:e}", v.value), format!("{:e}", v.lo));
            s.record([sec, name, e, &deg, &value, &lo]).expect(io);
        };
        for (name, v) in self.coordinates.iter().zip(&self.equilibrium) {
            row(&mut s, "equilibrium", name, "", String::new(), v);
        }
        row(&mut s, "energy", "E0", "", "0".into(), &self.energy);
        if let Some(g) = &self.gamma {
            row(&mut s, "gamma", "gamma", "", String::new(), g);
        }
        row(&mut s, "lambda", "lambda", "", "2".into(), &self.lambda);
        for ((name, v), sg) in self.omega_names().iter().zip(&self.omega).zip(&self.signs) {
            row(&mut s, "omega", name, &sg.to_string(), "2".into(), v);
        }
        let rn = self.reduced_names();
        for t in self.reduced.iter().filter(|t| t.coeff.value != 0.0) {
            row(
                &mut s,
                "reduced",
                &monomial(&rn, &t.exponents),
                &exps(&t.exponents),
                t.degree.to_string(),
                &t.coeff,
            );
        }
        let an = self.action_names();
        for t in &self.birkhoff {
            row(
                &mut s,
                "birkhoff",
                &monomial(&an, &t.exponents),
                &exps(&t.exponents),
                t.degree.to_string(),
                &t.coeff,
            );
        }
        let tm = &self.diagnostics.timings;
        for (name, x) in [
            ("taylor", tm.taylor),
            ("linear", tm.linear),
            ("reduction", tm.reduction),
            ("birkhoff", tm.birkhoff),
            ("transform", tm.transform),
            ("total", tm.total),
        ] {
            let v = Value {
                value: x,
                lo: 0.0,
                error: None,
            };
            row(&mut s, "timing", name, "", String::new(), &v);
        }
        String::from_utf8(s.into_inner().expect(io)).expect("the fields are UTF-8")
    }

    /// A human-readable report: the point, the linear frequencies, the reduced Hamiltonian
    /// through degree `min(N, 6)` (all of it in JSON/CSV), the Birkhoff coefficients and the
    /// timings.
    pub fn to_table(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "Centre manifold of {} at {} to degree {} ({} precision)",
            self.model, self.point, self.order, self.precision
        );
        let d = &self.diagnostics;
        let _ = writeln!(
            s,
            "\nequilibrium (|grad H| = {:.1e}, {} Newton steps):",
            d.gradient_norm, d.newton_iterations
        );
        for (name, v) in self.coordinates.iter().zip(&self.equilibrium) {
            let _ = writeln!(s, "  {name:>6} = {:>25}", value_str(v));
        }
        let _ = writeln!(s, "  H(z_eq) = {}", value_str(&self.energy));
        if let Some(g) = &self.gamma {
            let _ = writeln!(
                s,
                "  gamma = {}  (distance to the nearest primary)",
                value_str(g)
            );
        }
        let _ = writeln!(
            s,
            "\nlinear part: H2 = lambda Q1 P1 + sum sigma_k omega_k (Q_k^2 + P_k^2)/2"
        );
        let _ = writeln!(s, "  lambda = {}", value_str(&self.lambda));
        for ((name, v), sg) in self.omega_names().iter().zip(&self.omega).zip(&self.signs) {
            let _ = writeln!(s, "  {name} = {}  sigma = {sg:+}", value_str(v));
        }
        let show = self.order.min(6);
        let rn = self.reduced_names();
        let _ = writeln!(
            s,
            "\nreduced Hamiltonian H_cm - E0 on the centre manifold (Q1 = P1 = 0), degrees 2..{show} of {} (all in --format json/csv):",
            self.order
        );
        for t in self
            .reduced
            .iter()
            .filter(|t| t.degree <= show && t.coeff.value != 0.0)
        {
            let _ = writeln!(
                s,
                "  {:>3}  {:<28} {:>25}",
                t.degree,
                monomial(&rn, &t.exponents),
                value_str(&t.coeff)
            );
        }
        if !self.birkhoff.is_empty() {
            let an = self.action_names();
            let _ = writeln!(
                s,
                "\nBirkhoff normal form Hbar - E0 (I1 = Q1'P1' hyperbolic, I_k = (Q_k'^2 + P_k'^2)/2), smallest divisor {:.3}:",
                d.smallest_divisor.unwrap_or(f64::NAN)
            );
            for t in self.birkhoff.iter().filter(|t| t.degree <= show.max(8)) {
                let _ = writeln!(
                    s,
                    "  {:>3}  {:<28} {:>25}",
                    t.degree,
                    monomial(&an, &t.exponents),
                    value_str(&t.coeff)
                );
            }
        }
        let tm = &d.timings;
        let _ = writeln!(
            s,
            "\ntimings: {:.3} s total (expansion {:.3}, linear {:.3}, reduction {:.3}, Birkhoff {:.3}, maps {:.3})",
            tm.total, tm.taylor, tm.linear, tm.reduction, tm.birkhoff, tm.transform
        );
        let _ = writeln!(
            s,
            "checks: |A^T J A - J| = {:.1e}, |A^T S A - D| = {:.1e}, terms with a1 != b1 left = {:.1e}, imaginary part dropped = {:.1e}",
            d.symplectic_residual, d.diagonal_residual, d.hyperbolic_residual, d.reduced_imag_residual
        );
        s
    }

    /// A DSL model of the reduced Hamiltonian (two degrees of freedom for the spatial problem,
    /// one for the planar one): state `q = (Q₂…Q_n)`, `p = (P₂…P_n)`, `hamiltonian H = H_cm − E₀`,
    /// `structure canonical(q, p)`, so that `lasalle run` JIT-compiles and integrates the flow
    /// on the centre manifold.
    pub fn to_lsl(&self) -> String {
        let m = self.n_dof - 1;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "// @generated by lasalle normal-form --center-manifold: the reduced Hamiltonian of {} at {} to degree {}",
            self.model, self.point, self.order
        );
        let _ = writeln!(
            s,
            "// (Jorba & Masdemont partial normal form). q = (Q2..), p = (P2..) are the centre"
        );
        let _ = writeln!(
            s,
            "// coordinates; H = H_cm - E0 with E0 = {}.",
            lit(self.energy.value)
        );
        let name = format!(
            "CentreManifold{}",
            self.point.replace(|c: char| !c.is_ascii_alphanumeric(), "")
        );
        let (q, p) = if m == 1 {
            ("scalar", "scalar")
        } else {
            ("vec2", "vec2")
        };
        let _ = writeln!(s, "model {name} {{");
        let _ = writeln!(s, "    state q: {q}, p: {p};");
        let var = |v: usize| -> String {
            let (base, k) = if v < m { ("q", v) } else { ("p", v - m) };
            if m == 1 {
                base.to_string()
            } else {
                format!("{base}[{k}]")
            }
        };
        let mut terms = Vec::new();
        for t in self.reduced.iter().filter(|t| t.coeff.value != 0.0) {
            let mut f = vec![lit(t.coeff.value)];
            for (v, &e) in t.exponents.iter().enumerate() {
                match e {
                    0 => {}
                    1 => f.push(var(v)),
                    _ => f.push(format!("{}^{e}", var(v))),
                }
            }
            terms.push(f.join(" * "));
        }
        let _ = writeln!(
            s,
            "    hamiltonian H =\n        {};",
            terms.join("\n        + ")
        );
        let _ = writeln!(s, "    structure canonical(q, p);");
        let _ = writeln!(s, "}}");
        s.replace("+ -", "- ")
    }

    /// Rust source of a module with the reduced Hamiltonian and the coordinate changes (f64
    /// coefficients): `reduced_energy(w)`, `reduced_field(w)` (the flow on the centre
    /// manifold), `to_normal(z)`, `from_normal(w)`, `to_model(w)` (a point of the centre
    /// manifold in the model's coordinates) and `hyperbolic(z)` (Q₁', P₁' of a state: its
    /// distance from the manifold). Needs the transformation.
    pub fn to_rust(&self) -> Option<String> {
        let (to, from) = (self.to_normal_map.as_ref()?, self.from_normal_map.as_ref()?);
        let n = self.n_dof;
        let d = 2 * n;
        let r = d - 2;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "// @generated by lasalle-normal-form: centre manifold of {} at {} to degree {}.",
            self.model, self.point, self.order
        );
        let _ = writeln!(s, "//");
        let _ = writeln!(
            s,
            "// Coordinates z = ({}) in the model's canonical order.",
            self.coordinates.join(", ")
        );
        let _ = writeln!(s, "// Linear normal coordinates (Q, P) = A^-1 (z - z_eq), H2 = lambda Q1 P1 + sum omega_k (Q_k^2 + P_k^2)/2;");
        let _ = writeln!(s, "// (Q', P') after the Jorba-Masdemont reduction: Q1' = P1' = 0 is the centre manifold, on which");
        let _ = writeln!(
            s,
            "// w = (Q2'.., P2'..) follows the reduced Hamiltonian H_cm(w)."
        );
        let _ = writeln!(s, "#![allow(dead_code)]");
        let _ = writeln!(
            s,
            "\n/// Degrees of freedom of the full problem.\npub const N_DOF: usize = {n};"
        );
        let _ = writeln!(
            s,
            "/// Truncation degree.\npub const ORDER: usize = {};",
            self.order
        );
        let eq: Vec<String> = self
            .equilibrium
            .iter()
            .map(|v| lit(v.value + v.lo))
            .collect();
        let _ = writeln!(
            s,
            "/// The equilibrium z_eq.\npub const EQUILIBRIUM: [f64; {d}] = [{}];",
            eq.join(", ")
        );
        let _ = writeln!(
            s,
            "/// H(z_eq).\npub const ENERGY: f64 = {};",
            lit(self.energy.value + self.energy.lo)
        );
        let _ = writeln!(
            s,
            "/// lambda.\npub const LAMBDA: f64 = {};",
            lit(self.lambda.value + self.lambda.lo)
        );
        let om: Vec<String> = self.omega.iter().map(|v| lit(v.value + v.lo)).collect();
        let _ = writeln!(
            s,
            "/// Centre frequencies.\npub const OMEGA: [f64; {}] = [{}];",
            n - 1,
            om.join(", ")
        );
        let mat = |m: &Vec<Vec<f64>>| {
            m.iter()
                .map(|row| {
                    format!(
                        "[{}]",
                        row.iter().map(|&x| lit(x)).collect::<Vec<_>>().join(", ")
                    )
                })
                .collect::<Vec<_>>()
                .join(",\n    ")
        };
        let _ = writeln!(
            s,
            "/// A: z - z_eq = A (Q, P).\npub const LINEAR_MAP: [[f64; {d}]; {d}] = [\n    {}\n];",
            mat(&self.linear_map)
        );
        let _ = writeln!(
            s,
            "/// A^-1.\npub const LINEAR_INVERSE: [[f64; {d}]; {d}] = [\n    {}\n];",
            mat(&self.linear_inverse)
        );
        let _ = writeln!(s, "/// H_cm - E0 as (exponents of w, coefficient).\npub const REDUCED: &[([u8; {r}], f64)] = &[");
        for t in self.reduced.iter().filter(|t| t.coeff.value != 0.0) {
            let e: Vec<u8> = t.exponents.iter().map(|&x| x as u8).collect();
            let _ = writeln!(s, "    ({e:?}, {}),", lit(t.coeff.value + t.coeff.lo));
        }
        let _ = writeln!(s, "];");
        let map_terms = |m: &PolyMap| {
            let mut out = String::new();
            for p in &m.components {
                out.push_str("    &[\n");
                for (k, i, c) in p.terms() {
                    let _ = writeln!(out, "        ({:?}, {}),", p.exponents(k, i), lit(c));
                }
                out.push_str("    ],\n");
            }
            out
        };
        let _ = writeln!(s, "/// (Q', P') as polynomials in (Q, P).\npub const TO_NORMAL: [&[([u8; {d}], f64)]; {d}] = [\n{}];", map_terms(to));
        let _ = writeln!(s, "/// (Q, P) as polynomials in (Q', P').\npub const FROM_NORMAL: [&[([u8; {d}], f64)]; {d}] = [\n{}];", map_terms(from));
        let _ = write!(
            s,
            r#"
fn powers<const M: usize>(x: &[f64; M]) -> [[f64; {max1}]; M] {{
    let mut p = [[1.0; {max1}]; M];
    for (v, row) in p.iter_mut().enumerate() {{
        for k in 1..{max1} {{
            row[k] = row[k - 1] * x[v];
        }}
    }}
    p
}}

fn eval_map(terms: &[&[([u8; {d}], f64)]; {d}], x: &[f64; {d}]) -> [f64; {d}] {{
    let p = powers(x);
    let mut out = [0.0; {d}];
    for (o, comp) in out.iter_mut().zip(terms) {{
        *o = comp.iter().map(|(e, c)| e.iter().enumerate().fold(*c, |m, (v, &k)| m * p[v][k as usize])).sum();
    }}
    out
}}

/// H_cm(w) - E0 on the centre manifold, w = (Q2'.., P2'..).
pub fn reduced_energy(w: &[f64; {r}]) -> f64 {{
    let p = powers(w);
    REDUCED.iter().map(|(e, c)| e.iter().enumerate().fold(*c, |m, (v, &k)| m * p[v][k as usize])).sum()
}}

/// The reduced Hamiltonian's field dw/dt = J grad H_cm(w).
pub fn reduced_field(w: &[f64; {r}]) -> [f64; {r}] {{
    let p = powers(w);
    let mut grad = [0.0; {r}];
    for (e, c) in REDUCED {{
        for (k, g) in grad.iter_mut().enumerate() {{
            if e[k] == 0 {{
                continue;
            }}
            let mut m = c * e[k] as f64;
            for (v, &ev) in e.iter().enumerate() {{
                m *= p[v][if v == k {{ ev - 1 }} else {{ ev }} as usize];
            }}
            *g += m;
        }}
    }}
    let h = {r} / 2;
    let mut dw = [0.0; {r}];
    for k in 0..h {{
        dw[k] = grad[h + k];
        dw[h + k] = -grad[k];
    }}
    dw
}}

/// Normal coordinates (Q', P') of a model state z.
pub fn to_normal(z: &[f64; {d}]) -> [f64; {d}] {{
    let mut w = [0.0; {d}];
    for (i, wi) in w.iter_mut().enumerate() {{
        *wi = (0..{d}).map(|j| LINEAR_INVERSE[i][j] * (z[j] - EQUILIBRIUM[j])).sum();
    }}
    eval_map(&TO_NORMAL, &w)
}}

/// The model state of normal coordinates (Q', P').
pub fn from_normal(w: &[f64; {d}]) -> [f64; {d}] {{
    let l = eval_map(&FROM_NORMAL, w);
    let mut z = EQUILIBRIUM;
    for (i, zi) in z.iter_mut().enumerate() {{
        *zi += (0..{d}).map(|j| LINEAR_MAP[i][j] * l[j]).sum::<f64>();
    }}
    z
}}

/// The model state of a point w = (Q2'.., P2'..) of the centre manifold.
pub fn to_model(w: &[f64; {r}]) -> [f64; {d}] {{
    let h = {r} / 2;
    let mut full = [0.0; {d}];
    for k in 0..h {{
        full[1 + k] = w[k];
        full[{n} + 1 + k] = w[h + k];
    }}
    from_normal(&full)
}}

/// (Q1', P1') of a model state: zero on the centre manifold, growing like exp(+-lambda t) off it.
pub fn hyperbolic(z: &[f64; {d}]) -> [f64; 2] {{
    let w = to_normal(z);
    [w[0], w[{n}]]
}}
"#,
            max1 = self.order + 1,
        );
        Some(s)
    }
}
