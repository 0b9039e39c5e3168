//! `cargo run -p lasalle-normal-form --release --example normal_form -- models/cr3bp.lsl [mu] [order] [f64|dd] [table|json|csv|rust]`
use lasalle_normal_form::{normalize_model_file, ModelPoint, Options};

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let path = a
        .first()
        .cloned()
        .unwrap_or_else(|| "models/cr3bp.lsl".into());
    let mut params = Vec::new();
    if let Some(mu) = a.get(1).and_then(|s| s.parse::<f64>().ok()) {
        params.push(("mu".to_string(), mu));
    }
    let order = a.get(2).and_then(|s| s.parse().ok()).unwrap_or(12);
    let mut opts = Options::with_order(order);
    if let Some(p) = a.get(3) {
        opts.precision = p.parse().expect("precision");
    }
    match normalize_model_file(&path, &params, &ModelPoint::Auto, &opts) {
        Ok(nf) => match a.get(4).map(String::as_str) {
            Some("json") => println!("{}", nf.to_json()),
            Some("csv") => print!("{}", nf.to_csv()),
            Some("rust") => print!("{}", nf.to_rust().expect("transformation")),
            _ => print!("{}", nf.to_table()),
        },
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}
