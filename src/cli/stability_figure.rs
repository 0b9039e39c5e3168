//! The figure of `lasalle stability … --validate --figure DIR`: the bound T(d₀, d₁) per order
//! against d₀ with the integration horizon (no exit before it), and the measured action drift
//! against what the bound allows.

use std::path::Path;

use lasalle_analysis::canonical::CanonicalReport;

use super::plot::{write_figure, Chart, Series, Style};
use super::CliResult;

/// Writes `stability_time.svg` and `.png` into `dir`.
pub fn write(report: &CanonicalReport, dir: &Path) -> CliResult {
    let tubes: Vec<_> = report
        .tubes
        .iter()
        .filter(|t| t.validation.is_some())
        .collect();
    if tubes.is_empty() {
        return Err("--figure needs --validate".into());
    }
    let x: Vec<f64> = tubes.iter().map(|t| t.d0.log10()).collect();
    let orders: Vec<usize> = tubes[0].orders.iter().map(|r| r.order).collect();
    let mut bound = Chart {
        title: "bound T(d0, d1) vs integration".into(),
        x_label: "log10 d0".into(),
        y_label: "time".into(),
        log_y: true,
        equal_aspect: false,
        series: Vec::new(),
    };
    let mut drift = Chart {
        title: "drift of I1 + I2 over the horizon: measured (dots), allowed (lines)".into(),
        x_label: "log10 d0".into(),
        y_label: "|ΔΣI|".into(),
        log_y: true,
        equal_aspect: false,
        series: Vec::new(),
    };
    for (k, n) in orders.iter().enumerate() {
        let t: Vec<f64> = tubes
            .iter()
            .map(|t| t.orders[k].gradient.map_or(0.0, |g| g.lower))
            .collect();
        bound.series.push(Series {
            label: format!("T, N = {n}"),
            x: x.clone(),
            y: t,
            color: k,
            style: Style::Line,
        });
        let measured = |f: fn(&lasalle_analysis::canonical::Measured) -> f64| -> Vec<f64> {
            tubes
                .iter()
                .map(|t| t.validation.as_ref().map_or(0.0, |v| f(&v.measured[k])))
                .collect()
        };
        drift.series.push(Series {
            label: format!("measured, N = {n}"),
            x: x.clone(),
            y: measured(|m| m.action_drift),
            color: k,
            style: Style::Dots,
        });
        drift.series.push(Series {
            label: format!("bound, N = {n}"),
            x: x.clone(),
            y: measured(|m| m.drift_bound),
            color: k,
            style: Style::Line,
        });
    }
    let exit: Vec<f64> = tubes
        .iter()
        .map(|t| {
            let v = t.validation.as_ref().expect("validated");
            v.first_exit.unwrap_or(v.horizon)
        })
        .collect();
    bound.series.push(Series {
        label: "integrated to (first exit, else the horizon)".into(),
        x,
        y: exit,
        color: orders.len() % 6,
        style: Style::Dots,
    });
    write_figure(dir, "stability_time", &[bound, drift], (1, 2), (620, 480))
}
