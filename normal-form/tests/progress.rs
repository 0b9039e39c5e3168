//! Progress reports, option validation and the precision check of the library.

mod common;

use lasalle_normal_form::{ErrorEstimate, NormalFormError, Options, Precision, Progress, Stage};
use std::sync::{Arc, Mutex};

const EARTH_MOON: f64 = 0.01215058560962404;

#[test]
fn every_degree_is_reported_in_order() {
    let seen = Arc::new(Mutex::new(Vec::new()));
    let s = seen.clone();
    let mut opts = Options::with_order(10).estimate(ErrorEstimate::Rotation);
    opts.progress = Some(Progress(Arc::new(move |st| s.lock().unwrap().push(st))));
    common::l4_normal_form(EARTH_MOON, &opts).unwrap();
    let seen = seen.lock().unwrap();
    let degrees: Vec<usize> = seen
        .iter()
        .filter_map(|s| match s {
            Stage::Degree { degree, order, .. } => {
                assert_eq!(*order, 10);
                Some(*degree)
            }
            _ => None,
        })
        .collect();
    // the run, then the rotated rerun of the estimate
    let once: Vec<usize> = (3..=10).collect();
    assert_eq!(degrees, [once.clone(), once].concat());
    assert_eq!(seen.first(), Some(&Stage::Start(Precision::F64)));
    assert!(seen.contains(&Stage::Rerun(Precision::F64)));
    assert_eq!(seen.last(), Some(&Stage::Done));
}

#[test]
fn options_are_validated_by_name() {
    let cases: Vec<(Options, &str)> = vec![
        (
            Options {
                resonance_tol: f64::NAN,
                ..Options::with_order(6)
            },
            "resonance_tol = NaN",
        ),
        (
            Options {
                equilibrium_tol: -1.0,
                ..Options::with_order(6)
            },
            "equilibrium_tol = -1",
        ),
        (
            Options {
                max_relative_error: Some(f64::NAN),
                ..Options::with_order(6)
            },
            "max_relative_error",
        ),
        (Options::with_order(121), "order 121 outside 2…120"),
    ];
    for (o, want) in cases {
        match common::l4_normal_form(EARTH_MOON, &o) {
            Err(NormalFormError::Invalid(msg)) => assert!(msg.contains(want), "{msg}"),
            other => panic!("{want}: {other:?}"),
        }
    }
}

#[test]
fn precision_check_refuses_or_switches() {
    let f64_only = Options::with_order(20)
        .transform(false)
        .estimate(ErrorEstimate::OtherPrecision);
    match common::l4_normal_form(EARTH_MOON, &f64_only) {
        Err(NormalFormError::PrecisionLost {
            degree,
            relative_error,
            ..
        }) => {
            assert_eq!(degree, 18);
            assert!(relative_error > 1e-3, "{relative_error}");
        }
        other => panic!("expected the f64 breakdown, got {other:?}"),
    }
    let auto = f64_only.clone().auto_precision(true);
    let nf = common::l4_normal_form(EARTH_MOON, &auto).unwrap();
    assert_eq!(nf.precision, Precision::DoubleDouble);
    assert!(nf.diagnostics.precision_note.is_some());
    // the f64 result reused as the estimate of the dd one: every degree within 1e-10
    for d in &nf.diagnostics.hbar_degrees {
        assert!(d.max_relative_error.unwrap() < 1e-10, "{d:?}");
    }
    // the rotation estimate sees the same breakdown as the real f64 error
    let rotation = Options::with_order(20)
        .transform(false)
        .estimate(ErrorEstimate::Rotation);
    assert!(matches!(
        common::l4_normal_form(EARTH_MOON, &rotation),
        Err(NormalFormError::PrecisionLost { degree: 18, .. })
    ));
    // no estimate, no check
    let none = Options::with_order(20)
        .transform(false)
        .error_estimate(false);
    assert!(common::l4_normal_form(EARTH_MOON, &none).is_ok());
}
