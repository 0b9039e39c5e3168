//! Dumps of a [`NormalForm`]: JSON, CSV, a plain-text table and Rust code.

use crate::normal_form::{NormalForm, Value};
use lasalle_runtime::Csv;
use std::fmt::Write;

fn exps(e: &[u32]) -> String {
    e.iter()
        .map(|x| x.to_string())
        .collect::<Vec<_>>()
        .join(" ")
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

fn err_str(v: &Value) -> String {
    v.error.map_or(String::new(), |e| format!("{e:.1e}"))
}

fn rel_str(v: &Value) -> String {
    v.relative_error()
        .map_or(String::new(), |e| format!("{e:.1e}"))
}

fn value_str(v: &Value) -> String {
    if v.lo != 0.0 {
        format!("{:.17e} {:+.3e}", v.value, v.lo)
    } else {
        format!("{:.17e}", v.value)
    }
}

impl NormalForm {
    /// Names I1…In of the actions.
    fn action_names(&self) -> Vec<String> {
        (1..=self.n_dof).map(|k| format!("I{k}")).collect()
    }
    /// Names Q1…Qn, P1…Pn of the normal coordinates.
    fn normal_names(&self) -> Vec<String> {
        (1..=self.n_dof)
            .map(|k| format!("Q{k}"))
            .chain((1..=self.n_dof).map(|k| format!("P{k}")))
            .collect()
    }

    /// Everything as pretty JSON (the transformation maps are left out; see [`NormalForm::to_rust`]).
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("serialisable")
    }

    /// One row per number: `section,name,exponents,degree,value,lo,error`.
    ///
    /// Sections: `equilibrium`, `energy`, `omega` (name `omega<k>` with its sign σ_k in the
    /// exponents column), `hbar` (exponents of I₁…I_n), `d4` (A, B, C, D4), `generating`
    /// (exponents of Q₁…Q_n, P₁…P_n), `divisor` (exponents = m, value = m·ω, degree = first
    /// order met), `resonant` (exponents of x then y; value = Re, lo = Im).
    pub fn to_csv(&self) -> String {
        let mut s = Csv::new(Vec::new());
        let io = "writing to memory does not fail";
        s.record([
            "section",
            "name",
            "exponents",
            "degree",
            "value",
            "lo",
            "error",
        ])
        .expect(io);
        let row = |s: &mut Csv<Vec<u8>>, sec: &str, name: &str, e: &str, deg: String, v: &Value| {
            let (value, lo) = (format!("{:e}", v.value), format!("{:e}", v.lo));
            let error = v.error.map_or(String::new(), |x| format!("{x:e}"));
            s.record([sec, name, e, &deg, &value, &lo, &error])
                .expect(io);
        };
        for (name, v) in self.coordinates.iter().zip(&self.equilibrium) {
            row(&mut s, "equilibrium", name, "", String::new(), v);
        }
        row(&mut s, "energy", "E0", "", "0".into(), &self.energy);
        for (k, (v, sg)) in self.omega.iter().zip(&self.signs).enumerate() {
            row(
                &mut s,
                "omega",
                &format!("omega{}", k + 1),
                &sg.to_string(),
                "2".into(),
                v,
            );
        }
        let an = self.action_names();
        for t in &self.hamiltonian {
            row(
                &mut s,
                "hbar",
                &monomial(&an, &t.exponents),
                &exps(&t.exponents),
                t.degree.to_string(),
                &t.coeff,
            );
        }
        if let Some(d) = &self.d4 {
            for (name, v) in [("A", &d.a), ("B", &d.b), ("C", &d.c), ("D4", &d.d4)] {
                row(&mut s, "d4", name, "", "4".into(), v);
            }
        }
        let nn = self.normal_names();
        for t in &self.generating_function {
            row(
                &mut s,
                "generating",
                &monomial(&nn, &t.exponents),
                &exps(&t.exponents),
                t.degree.to_string(),
                &t.coeff,
            );
        }
        for d in &self.small_divisors {
            let e =
                d.m.iter()
                    .map(|x| x.to_string())
                    .collect::<Vec<_>>()
                    .join(" ");
            let v = Value {
                value: d.m_dot_omega,
                lo: 0.0,
                error: None,
            };
            row(
                &mut s,
                "divisor",
                if d.resonant { "resonant" } else { "m" },
                &e,
                d.order.to_string(),
                &v,
            );
        }
        for r in &self.resonant_terms {
            let e = format!("{} {}", exps(&r.x), exps(&r.y));
            let v = Value {
                value: r.re,
                lo: r.im,
                error: None,
            };
            let deg = (r.x.iter().sum::<u32>() + r.y.iter().sum::<u32>()).to_string();
            row(&mut s, "resonant", "x^a y^b", &e, deg, &v);
        }
        String::from_utf8(s.into_inner().expect(io)).expect("the fields are UTF-8")
    }

    /// A human-readable report.
    pub fn to_table(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "Birkhoff normal form of {} to degree {} ({} precision{}{})",
            self.model,
            self.order,
            self.precision,
            if self.resonant { ", resonant" } else { "" },
            self.diagnostics
                .error_method
                .as_ref()
                .map_or(String::new(), |m| format!(", errors estimated as {m}"))
        );
        let _ = writeln!(
            s,
            "\nequilibrium (|grad H| = {:.1e}, {} Newton steps):",
            self.diagnostics.gradient_norm, self.diagnostics.newton_iterations
        );
        for (name, v) in self.coordinates.iter().zip(&self.equilibrium) {
            let _ = writeln!(s, "  {name:>6} = {:>25}  {}", value_str(v), err_str(v));
        }
        let _ = writeln!(s, "  H(z_eq) = {}", value_str(&self.energy));
        let _ = writeln!(s, "\nlinear frequencies (H2 = sum sigma_k omega_k I_k):");
        for (k, (v, sg)) in self.omega.iter().zip(&self.signs).enumerate() {
            let _ = writeln!(
                s,
                "  omega{} = {:>25}  sigma = {:+}  {}",
                k + 1,
                value_str(v),
                sg,
                err_str(v)
            );
        }
        if let Some(note) = &self.diagnostics.precision_note {
            let _ = writeln!(s, "\nnote: {note}");
        }
        if self.resonant_terms.is_empty() {
            let _ = writeln!(
                s,
                "\nnormal form  Hbar = H(z_eq) + sum_a h_a I^a,  I_k = (Q_k^2 + P_k^2)/2 in normal coordinates:"
            );
        } else {
            let _ = writeln!(
                s,
                "\nresonant normal form: Hbar = H(z_eq) + (terms x^a y^a below, written in the actions \
                 I_k = (Q_k^2 + P_k^2)/2 = i x_k y_k) + (the resonant terms further below); it is not a \
                 function of the actions alone, so there is no frequency map and no D4:"
            );
        }
        let _ = writeln!(
            s,
            "  {:<14} {:>6} {:>26} {:>10} {:>10}",
            "monomial", "degree", "h_a", "abs.err", "rel.err"
        );
        let an = self.action_names();
        for t in &self.hamiltonian {
            let _ = writeln!(
                s,
                "  {:<14} {:>6} {:>26} {:>10} {:>10}",
                monomial(&an, &t.exponents),
                t.degree,
                value_str(&t.coeff),
                err_str(&t.coeff),
                rel_str(&t.coeff)
            );
        }
        if let Some(d) = &self.d4 {
            let _ = writeln!(s, "\nArnold-Moser (Hbar_4 = (A I1^2 + 2B I1 I2 + C I2^2)/2, D4 = A nu2^2 - 2B nu1 nu2 + C nu1^2, nu = sigma omega):");
            for (name, v) in [("A", &d.a), ("B", &d.b), ("C", &d.c), ("D4", &d.d4)] {
                let _ = writeln!(s, "  {name:>2} = {:>25}  {}", value_str(v), err_str(v));
            }
        }
        if !self.resonant_terms.is_empty() {
            let _ = writeln!(
                s,
                "\nresonant terms kept, c x^a y^b with x_k = (Q_k - i P_k)/sqrt2, y_k = (P_k - i Q_k)/sqrt2 \
                 (Q, P: the normal coordinates):"
            );
            for r in &self.resonant_terms {
                let _ = writeln!(
                    s,
                    "  x^{:?} y^{:?}: {:.17e} {:+.17e}i",
                    r.x, r.y, r.re, r.im
                );
            }
        }
        let shown = self.small_divisors.len().min(10);
        let _ = writeln!(
            s,
            "\nsmall divisors met ({} smallest of {}):",
            shown,
            self.small_divisors.len()
        );
        for d in &self.small_divisors[..shown] {
            let _ = writeln!(
                s,
                "  m = {:<12} m.omega = {:>12.6e}  first at degree {}{}",
                format!("{:?}", d.m),
                d.m_dot_omega,
                d.order,
                if d.resonant { "  (kept: resonant)" } else { "" }
            );
        }
        let nn = self.normal_names();
        let _ = writeln!(
            s,
            "\ngenerating function: {} terms in G3..G{} (real, in the linear normal coordinates); G3 and G4:",
            self.generating_function.len(),
            self.order
        );
        for t in self.generating_function.iter().filter(|t| t.degree <= 4) {
            let _ = writeln!(
                s,
                "  {:<24} {:>26} {:>10}",
                monomial(&nn, &t.exponents),
                value_str(&t.coeff),
                err_str(&t.coeff)
            );
        }
        let d = &self.diagnostics;
        let largest = self
            .hamiltonian
            .iter()
            .map(|t| t.coeff.value.abs())
            .fold(0.0, f64::max);
        let _ = writeln!(
            s,
            "\nchecks: |A^T J A - J| = {:.1e}, |A^T S A - diag| = {:.1e}, |Im Hbar| = {:.1e} of its largest coefficient{}",
            d.symplectic_residual,
            d.diagonal_residual,
            d.hbar_imag_residual / largest.max(f64::MIN_POSITIVE),
            d.amplification.map_or(String::new(), |a| format!(
                ", rounding amplification {a:.1e}"
            ))
        );
        let worst = d
            .hbar_degrees
            .iter()
            .filter_map(|x| x.max_relative_error.map(|e| (x.degree, e)))
            .max_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((degree, e)) = worst {
            let _ = writeln!(
                s,
                "worst estimated relative error of a coefficient of Hbar: {e:.1e} (degree {degree})"
            );
        }
        let t = &d.timings;
        let _ = write!(
            s,
            "time: {:.4} s (taylor {:.4}, linear {:.4}, lie {:.4}, transform {:.4})",
            t.total, t.taylor, t.linear, t.lie, t.transform
        );
        if t.error_estimate > 0.0 {
            let _ = write!(
                s,
                " + error estimate ({}) {:.4} s = {:.1}x the run",
                d.error_method.as_deref().unwrap_or("second run"),
                t.error_estimate,
                t.error_estimate / t.total.max(1e-12)
            );
        }
        let _ = writeln!(s);
        s
    }
}
