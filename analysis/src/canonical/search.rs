//! The orders of the bounds, computed from one normalisation at a time
//! ([`normalize_model_orders`]: each order reuses the generators, transformed terms and maps
//! of the lower ones), each order's rows told as soon as they are computed, and, with the
//! order search, stopped for each tube when its bound has peaked, when the first order gives
//! none, or when the time budget is spent.

use std::time::Instant;

use super::{
    default_remainder_degree, options, radius_at_order, tube_row, CanonicalOptions, Form,
    OrderBound, RadiusAtOrder, SearchEnd, SearchEvent,
};
use lasalle_model::Model;
use lasalle_normal_form::bound::{Bound, Norm};
use lasalle_normal_form::{normalize_model_orders, NormalFormError, Options, Precision};

/// Orders normalised together while searching: the table reaches the remainder degree of the
/// last of them from the start, so a longer run costs its first orders more.
const SEARCH_CHUNK: usize = 4;

/// What the orders gave.
pub(super) struct Searched {
    /// The orders computed.
    pub orders: Vec<usize>,
    /// Their normal forms and bounds.
    pub forms: Vec<Form>,
    /// Per tube, its rows (a tube whose search ended has fewer).
    pub rows_by_tube: Vec<Vec<OrderBound>>,
    /// Per `for_time`, its rows.
    pub radii: Vec<Vec<RadiusAtOrder>>,
    /// The precision of the last order.
    pub precision: Precision,
    /// The orders the bounds may use (4, 6, …, the highest allowed).
    pub candidates: Vec<usize>,
    /// With the order search: why it ended, per tube.
    pub tube_ends: Vec<Option<SearchEnd>>,
    /// With the order search: why it ended, per `for_time`.
    pub radius_ends: Vec<Option<SearchEnd>>,
}

/// Is the last value below the best before it (`None` counts as below)?
fn past_best(values: &[Option<f64>]) -> bool {
    let best = values[..values.len() - 1]
        .iter()
        .flatten()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    best.is_finite() && values.last().copied().flatten().is_none_or(|v| v < best)
}

/// The end of a search with these values at these orders, if it has ended: peaked (past the
/// best), or (`first_decides`) no value at the first order.
fn end_of(values: &[Option<f64>], orders: &[usize], first_decides: bool) -> Option<SearchEnd> {
    if first_decides && values.len() == 1 && values[0].is_none() {
        return Some(SearchEnd::NoBound { order: orders[0] });
    }
    if values.len() < 2 || !past_best(values) {
        return None;
    }
    let best = values
        .iter()
        .zip(orders)
        .filter_map(|(v, &n)| v.map(|v| (n, v)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(n, _)| n)?;
    Some(SearchEnd::Peaked {
        best,
        next: orders[values.len() - 1],
    })
}

/// The orders 4, 6, …, `max_order` (and `max_order` if odd).
pub(super) fn candidates(max_order: usize) -> Vec<usize> {
    let mut v: Vec<usize> = (4..=max_order).step_by(2).collect();
    if max_order % 2 == 1 {
        v.push(max_order);
    }
    v
}

/// The search's state between orders.
struct State<'e> {
    out: Searched,
    on_event: &'e mut dyn FnMut(SearchEvent<'_>),
    last: Instant,
    started: Instant,
    stop: bool,
}

/// The rows of one order's normal form, told as they come; whether to go on.
fn take_order(st: &mut State<'_>, o: &CanonicalOptions, f: Form) -> Result<bool, NormalFormError> {
    let n = f.nf.order;
    let out = &mut st.out;
    out.precision = f.nf.precision;
    let active = |ends: &[Option<SearchEnd>], k: usize| !o.optimal || ends[k].is_none();
    for (k, &(d0, d1)) in o.tubes.iter().enumerate() {
        if active(&out.tube_ends, k) {
            let row = tube_row(&f, d0, d1, o.metric)?;
            (st.on_event)(SearchEvent::Row { tube: k, row: &row });
            out.rows_by_tube[k].push(row);
        }
    }
    for (k, &time) in o.for_time.iter().enumerate() {
        if active(&out.radius_ends, k) {
            // start from the previous order's radius (they change slowly with N)
            let start = out.radii[k].iter().rev().find_map(|r| r.d0).unwrap_or(1e-3);
            let row = radius_at_order(&f, time, o.outer_ratio, o.metric, start)?;
            (st.on_event)(SearchEvent::Radius {
                index: k,
                row: &row,
            });
            out.radii[k].push(row);
        }
    }
    out.orders.push(n);
    out.forms.push(f);
    let cost = st.last.elapsed().as_secs_f64();
    st.last = Instant::now();
    if !o.optimal {
        return Ok(true);
    }
    for (k, rows) in out.rows_by_tube.iter().enumerate() {
        if out.tube_ends[k].is_none() {
            let v: Vec<Option<f64>> = rows.iter().map(|r| r.gradient.map(|t| t.lower)).collect();
            let orders: Vec<usize> = rows.iter().map(|r| r.order).collect();
            if let Some(end) = end_of(&v, &orders, true) {
                (st.on_event)(SearchEvent::TubeEnd { tube: k, end: &end });
                out.tube_ends[k] = Some(end);
            }
        }
    }
    for (k, rows) in out.radii.iter().enumerate() {
        if out.radius_ends[k].is_none() {
            let v: Vec<Option<f64>> = rows.iter().map(|r| r.d0).collect();
            let orders: Vec<usize> = rows.iter().map(|r| r.order).collect();
            if let Some(end) = end_of(&v, &orders, false) {
                (st.on_event)(SearchEvent::RadiusEnd {
                    index: k,
                    end: &end,
                });
                out.radius_ends[k] = Some(end);
            }
        }
    }
    let open = out
        .tube_ends
        .iter()
        .chain(&out.radius_ends)
        .any(|e| e.is_none());
    let next = out.candidates.iter().find(|&&m| m > n).copied();
    let spent = st.started.elapsed().as_secs_f64();
    let over = o.budget.is_some_and(|b| spent + cost > b);
    if open && next.is_some() && over {
        // the next order costs at least as much as this one
        let budget = o.budget.unwrap_or(0.0);
        let end = SearchEnd::Budget { budget, last: n };
        for k in 0..out.tube_ends.len() {
            if out.tube_ends[k].is_none() {
                (st.on_event)(SearchEvent::TubeEnd { tube: k, end: &end });
                out.tube_ends[k] = Some(end.clone());
            }
        }
        for k in 0..out.radius_ends.len() {
            if out.radius_ends[k].is_none() {
                (st.on_event)(SearchEvent::RadiusEnd {
                    index: k,
                    end: &end,
                });
                out.radius_ends[k] = Some(end.clone());
            }
        }
        return Ok(false);
    }
    if let (true, Some(m)) = (open, next) {
        (st.on_event)(SearchEvent::Order {
            order: m,
            seconds: spent,
        });
    }
    Ok(open)
}

/// Computes the orders: given (4, 6, …, N) in one normalisation, or searched in chunks of
/// [`SEARCH_CHUNK`] orders, each chunk starting in the precision the last one ended in.
pub(super) fn search_orders(
    model: &Model,
    params: &[(String, f64)],
    o: &CanonicalOptions,
    started: Instant,
    on_event: &mut dyn FnMut(SearchEvent<'_>),
) -> Result<Searched, NormalFormError> {
    let candidates = candidates(o.max_order);
    let with_m: Vec<(usize, usize)> = candidates
        .iter()
        .map(|&n| {
            let m = o
                .remainder_degree
                .map_or(default_remainder_degree(n), |m| m.max(n + 1));
            (n, m)
        })
        .collect();
    let chunks: Vec<&[(usize, usize)]> = if o.optimal {
        with_m.chunks(SEARCH_CHUNK).collect()
    } else {
        vec![&with_m[..]]
    };
    let mut st = State {
        out: Searched {
            orders: Vec::new(),
            forms: Vec::new(),
            rows_by_tube: vec![Vec::new(); o.tubes.len()],
            radii: vec![Vec::new(); o.for_time.len()],
            precision: Precision::F64,
            candidates: candidates.clone(),
            tube_ends: vec![None; o.tubes.len()],
            radius_ends: vec![None; o.for_time.len()],
        },
        on_event,
        last: Instant::now(),
        started,
        stop: false,
    };
    (st.on_event)(SearchEvent::Order {
        order: candidates[0],
        seconds: started.elapsed().as_secs_f64(),
    });
    for chunk in chunks {
        let opts = Options {
            // the bounds and the validation use the map to the normal coordinates only
            inverse_transform: false,
            progress: o.progress.clone(),
            ..options(chunk[0].0, None).precision(st.out.precision)
        };
        let mut failed = None;
        normalize_model_orders(model, params, &o.point, &opts, chunk, &mut |nf| {
            let rem = nf.remainder.as_ref().expect("remainder requested");
            let f = Form {
                bound: Bound::new(rem, Norm::Gradient),
                radial: Bound::new(rem, Norm::Radial),
                m: rem.degree,
                seconds: st.last.elapsed().as_secs_f64(),
                nf,
            };
            match take_order(&mut st, o, f) {
                Ok(go) => {
                    st.stop = !go;
                    go
                }
                Err(e) => {
                    failed = Some(e);
                    false
                }
            }
        })?;
        if let Some(e) = failed {
            return Err(e);
        }
        if st.stop {
            break;
        }
    }
    let mut out = st.out;
    if o.optimal {
        let last = out.orders.last().copied().unwrap_or(4);
        for e in out.tube_ends.iter_mut().chain(out.radius_ends.iter_mut()) {
            if e.is_none() {
                *e = Some(SearchEnd::Ceiling { last });
            }
        }
    }
    Ok(out)
}
