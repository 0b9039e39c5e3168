//! The vocabulary table is the language: every built-in lowers, every name in it is reserved,
//! docs/dsl.md shows exactly the table, and problems are classified by their kind.

use lasalle_model::vocabulary::{
    functions_markdown, keywords_markdown, Arity, Lowering, BUILTINS, KEYWORDS,
};
use lasalle_model::{check, derive, lower_source, DiagnosticKind, Error};

/// The front end on `text`: parse, lower, derive and check (what emission would be given).
fn front_end(path: &str, text: &str) -> Result<(), Error> {
    check(&derive(lower_source(path, text)?))?;
    Ok(())
}

/// A call of each built-in that lowers in a model with `state x: vec3, R: mat3, u: scalar` and
/// `param a = 0.5` (a test fails if a new built-in has no example here).
fn example(name: &str) -> &'static str {
    match name {
        "sqrt" => "sqrt(1 + u^2)",
        "exp" => "exp(u)",
        "log" => "log(2 + u^2)",
        "sin" => "sin(u)",
        "cos" => "cos(u)",
        "sign" => "sign(u)",
        "delay" => "delay(u, a)",
        "norm" => "norm(x)",
        "dot" => "dot(x, x)",
        "cross" => "cross(x, x)[0]",
        "hat" => "hat(x)[0, 1]",
        "transpose" => "transpose(R)[0, 1]",
        "trace" => "trace(R)",
        "inv" => "inv(diag(a, 2, 3))[0, 0]",
        "eye" => "eye(3)[1, 1]",
        "diag" => "diag(x)[2, 2]",
        "target" => "target(E)", // in `lyapunov` only
        "sn" | "cn" | "dn" | "ns" | "nc" | "nd" | "sc" | "sd" | "cs" | "cd" | "ds" | "dc" => {
            match name {
                "sn" => "sn(u, a)",
                "cn" => "cn(u, a)",
                "dn" => "dn(u, a)",
                "ns" => "ns(u, a)",
                "nc" => "nc(u, a)",
                "nd" => "nd(u, a)",
                "sc" => "sc(u, a)",
                "sd" => "sd(u, a)",
                "cs" => "cs(u, a)",
                "cd" => "cd(u, a)",
                "ds" => "ds(u, a)",
                _ => "dc(u, a)",
            }
        }
        "ellipk" => "ellipk(a)",
        "ellipf" => "ellipf(u, a)",
        other => panic!("no example call of the built-in `{other}`: add one"),
    }
}

fn model_with(expr: &str) -> String {
    format!(
        "model V {{ state x: vec3, R: mat3, u: scalar; param a = 0.5;
         d/dt x = [0, 0, 0]; d/dt R = eye(3) * 0; d/dt u = 0;
         integral E = u;
         let probe = {expr};
         lyapunov V = (E - target(E))^2 + 0 * probe; }}"
    )
}

#[test]
fn every_builtin_lowers() {
    for b in BUILTINS {
        let call = example(b.name);
        let text = if b.name == "target" {
            model_with("1")
        } else {
            model_with(call)
        };
        if let Err(e) = lower_source("v.lsl", &text) {
            panic!("`{call}` does not lower: {e}");
        }
        let (args, _) = call.split_at(call.find('(').expect("a call"));
        assert_eq!(args, b.name);
        // a wrong number of arguments is a located error naming the signature
        let wrong = match b.arity {
            Arity::Exactly(n) => vec!["u"; n + 1].join(", "),
            Arity::AtLeast(_) => String::new(),
        };
        let Err(e) = lower_source("v.lsl", &model_with(&format!("{}({wrong})", b.name))) else {
            panic!("`{}` accepted a wrong number of arguments", b.name);
        };
        let msg = e.to_string();
        assert!(
            msg.contains(&format!("`{}` takes", b.name)) && msg.contains(b.call),
            "{msg}"
        );
    }
}

fn kinds(text: &str) -> Vec<DiagnosticKind> {
    match front_end("k.lsl", text) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e.diagnostics().iter().map(|d| d.kind).collect(),
    }
}

#[test]
fn builtins_and_keywords_are_reserved() {
    let names = BUILTINS
        .iter()
        .map(|b| b.name)
        .chain(KEYWORDS.iter().map(|k| k.name).filter(|k| *k != "d/dt"));
    for name in names {
        let text = format!("model M {{ state x: scalar; let {name} = x; d/dt x = -x; }}");
        assert_eq!(kinds(&text), [DiagnosticKind::Reserved], "{name}");
    }
}

#[test]
fn docs_show_the_tables() {
    let doc = include_str!("../../docs/dsl.md");
    for (what, table) in [
        ("functions", functions_markdown()),
        ("keywords", keywords_markdown()),
    ] {
        assert!(
            doc.contains(&table),
            "docs/dsl.md does not hold the {what} table of `lasalle_model::vocabulary`; \
             replace it with:\n{table}"
        );
    }
    // every function named in a `code` span of the docs' tables exists (and conversely, by
    // the tables above)
    for b in BUILTINS {
        assert!(
            doc.contains(&format!("`{}`", b.call)),
            "{} undocumented",
            b.name
        );
    }
}

#[test]
fn lowering_rows_are_consistent() {
    for b in BUILTINS {
        match b.lowering {
            Lowering::Func(f) => assert_eq!(f.name(), b.name),
            Lowering::Func2(f) => assert_eq!(f.name(), b.name),
            Lowering::Quotient(p, q) => {
                let letter = |f: Option<lasalle_model::ir::Func2>| {
                    f.map_or('n', |f| f.name().chars().next().unwrap())
                };
                assert_eq!(format!("{}{}", letter(p), letter(q)), b.name);
            }
            Lowering::Sqrt | Lowering::Structural | Lowering::Sign | Lowering::Delay => {}
        }
    }
    let mut names: Vec<&str> = BUILTINS.iter().map(|b| b.name).collect();
    names.sort();
    names.dedup();
    assert_eq!(names.len(), BUILTINS.len(), "a built-in is listed twice");
}

#[test]
fn diagnostics_have_kinds() {
    let m = |body: &str| format!("model M {{ state x: scalar, y: scalar; param a = 0.5; {body} }}");
    assert_eq!(kinds("model M { state x: ; }"), [DiagnosticKind::Syntax]);
    assert_eq!(
        kinds(&m("d/dt x = z; d/dt y = 0;")),
        [DiagnosticKind::UnknownName]
    );
    assert_eq!(
        kinds(&m("d/dt x = nrm(x); d/dt y = 0;")),
        [DiagnosticKind::UnknownName]
    );
    assert_eq!(
        kinds(&m("d/dt x = 1/0; d/dt y = 0;")),
        [DiagnosticKind::NotFinite]
    );
    assert_eq!(
        kinds(&m("integral E = x gain k = 2; d/dt x = k; d/dt y = 0;")),
        [DiagnosticKind::NotAllowedHere]
    );
    assert_eq!(
        kinds(&m("d/dt x = y; d/dt y = -x; integral E = x^2 + 2*y^2;")),
        [DiagnosticKind::FailedCheck]
    );
    // a failed `let` is reported once, not again at each use
    assert_eq!(
        kinds(&m("let b = q; d/dt x = b; d/dt y = b;")),
        [DiagnosticKind::UnknownName]
    );
}

/// The parameter m of an elliptic function may not depend on the state: a located error at m.
#[test]
fn elliptic_parameter_must_not_depend_on_the_state() {
    let text = "model M {\n  state x: scalar, y: scalar;\n  let m = y^2 / 2;\n  d/dt x = sn(x, m);\n  d/dt y = 0;\n}\n";
    let e = front_end("models/e.lsl", text).unwrap_err();
    let d = &e.diagnostics()[0];
    assert_eq!(d.kind, DiagnosticKind::StateDependentParameter);
    let msg = e.to_string();
    assert!(
        msg.contains("models/e.lsl:4:18")
            && msg.contains("the parameter m of `sn` depends on the state"),
        "{msg}"
    );
    // …in quotients, K and F alike; a constant m outside [0, 1] is refused too
    for call in ["sc(x, y)", "ellipk(x)", "ellipf(0.5, x)"] {
        let text =
            format!("model M {{ state x: scalar, y: scalar; d/dt x = {call}; d/dt y = 0; }}");
        assert_eq!(
            kinds(&text),
            [DiagnosticKind::StateDependentParameter],
            "{call}"
        );
    }
    let e = front_end("e.lsl", "model M { state x: scalar; d/dt x = cn(x, 1.5); }")
        .unwrap_err()
        .to_string();
    assert!(e.contains("is 1.5, outside [0, 1]"), "{e}");
    // parameters, lets of parameters and numbers are fine
    let ok = "model M { state x: scalar; param k = 0.8; let m = k^2; d/dt x = dn(x, m) + ellipk(m) + ellipf(x, 0.3) + ds(1 + x^2, 1); }";
    assert!(front_end("e.lsl", ok).is_ok());
}

/// Constant calls fold with the runtime's kernels, in parameter defaults too.
#[test]
fn constant_elliptic_calls_fold() {
    let text =
        "model M { state x: scalar; param K = ellipk(0.5); d/dt x = K * sn(ellipk(0.5), 0.5); }";
    let m = lower_source("f.lsl", text).unwrap();
    let k = lasalle_elliptic::ellipk(0.5);
    assert_eq!(m.default_params(), vec![k]);
    // sn(K | m) = 1 folded to a number, times the parameter K
    let v = m.graph.eval_f64(&[m.field[0]], &mut |_| k)[0];
    assert!((v - k).abs() < 1e-15 * k, "{v}");
    assert!(matches!(
        lower_source("f.lsl", "model M { state x: scalar; d/dt x = ns(0, 0.5); }"),
        Err(Error::Model(_))
    ));
}
