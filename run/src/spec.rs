//! [`RunSpec`]: everything about a run except the model and the initial state; and
//! [`RunSpecBuilder`], which resolves one from a model's run preset and the caller's overrides
//! as `lasalle run` does from its flags.

use lasalle_runtime::{rtol_floor, GainPolicy, ModelInfo, Parameters, Preset, DEFAULT_MAX_DRIFT};

use crate::input::initial_state;
use crate::{Base, Interrupt, Method, MethodSetting, RunError};

/// The number of samples a run records when [`RunSpec::every`] is 0.
pub const AUTO_SAMPLES: u64 = 20_000;

/// The default step budget: 10⁹ steps, minutes at tens of nanoseconds a step.
pub const DEFAULT_MAX_STEPS: u64 = 1_000_000_000;

/// Everything about a run except the model and the initial state (diffsol's split: the model
/// and x₀ are the problem, the spec the method that solves it).
#[derive(Clone, Debug, PartialEq)]
pub struct RunSpec {
    /// The method.
    pub method: Method,
    /// Step size (fixed-step methods) or initial step (adaptive methods; 0 = chosen by the
    /// method: Hairer, Nørsett & Wanner's starting step for DOPRI5, Jorba & Zou's for Taylor).
    pub dt: f64,
    /// End time (the run starts at t = 0); negative: the run goes backwards, to t_end.
    pub t_end: f64,
    /// Gains of feedback methods.
    pub gains: GainPolicy,
    /// Tolerance of the projection on |f(x) − f(x₀)|₂.
    pub tol: f64,
    /// Relative tolerance of `dopri5`; the tolerance ε of the Taylor method.
    pub rtol: f64,
    /// Absolute tolerance of `dopri5` (the Taylor method has the one tolerance `rtol`).
    pub atol: f64,
    /// An invariant whose error exceeds `max_drift` times its scale ends the run as diverged
    /// ([`DriftBound`](lasalle_runtime::DriftBound)).
    pub max_drift: f64,
    /// Record every `every`-th step (0: about [`AUTO_SAMPLES`] samples; an adaptive run,
    /// whose step count is not known in advance, records every step for its first
    /// [`AUTO_SAMPLES`] samples, every second step for as many, every fourth, …, so that a
    /// run of n steps keeps about [`AUTO_SAMPLES`]·log₂(n/[`AUTO_SAMPLES`]) samples).
    pub every: u64,
    /// The most steps the run may take (fixed-step runs longer than this are refused before
    /// they start; adaptive runs stop with an error when they reach it).
    pub max_steps: u64,
    /// Output times (sorted in the run's direction, within [0, t_end]): the run records the state there, from each
    /// method's continuous extension, instead of every [`RunSpec::every`]-th step; adaptive
    /// methods keep their own steps. Empty: record steps.
    pub t_eval: Vec<f64>,
    /// Stops the run from outside ([`Interrupt`]); `None`: the run goes to its end.
    pub interrupt: Option<Interrupt>,
    /// Locate and record the model's events (default). `false`: only its `stop` events are
    /// watched (they end the run), the others are not located — for runs whose crossings
    /// nobody reads (sweeps), which then skip the watch's interpolations at every step.
    pub record_events: bool,
    /// The solutions of a discontinuous field (`sign(g)`): classical or Filippov's.
    pub switching: crate::Switching,
}

impl RunSpec {
    /// A spec with the defaults of `lasalle run`: default gains (the model's, bounded by the
    /// stability interval, for fixed-step methods; the step-tracking rule for adaptive ones),
    /// projection tolerance dt (rtol if dt
    /// is 0), rtol = atol = 1e-10, divergence past [`DEFAULT_MAX_DRIFT`], about
    /// [`AUTO_SAMPLES`] samples, at most [`DEFAULT_MAX_STEPS`] steps.
    pub fn new(method: Method, dt: f64, t_end: f64) -> Self {
        let rtol = 1e-10;
        RunSpec {
            method,
            dt,
            t_end,
            gains: GainPolicy::Default,
            tol: if dt > 0.0 { dt } else { rtol },
            rtol,
            atol: rtol,
            max_drift: DEFAULT_MAX_DRIFT,
            every: 0,
            max_steps: DEFAULT_MAX_STEPS,
            t_eval: Vec::new(),
            interrupt: None,
            record_events: true,
            switching: crate::Switching::Classical,
        }
    }

    /// A builder without a preset: every setting is the caller's or the default.
    pub fn builder() -> RunSpecBuilder {
        RunSpecBuilder::default()
    }

    /// A builder that starts from `preset` (a model's `run NAME { … }`, e.g.
    /// [`find_preset`]`(&model, None)?` or `LoadedModel::preset("paper")`); the builder's
    /// setters override its settings.
    pub fn from_preset(preset: Option<&Preset>) -> RunSpecBuilder {
        RunSpecBuilder {
            preset: preset.cloned(),
            ..RunSpecBuilder::default()
        }
    }

    /// The number of steps of a fixed-step run (an estimate for adaptive ones).
    pub fn steps(&self) -> u64 {
        if self.dt > 0.0 {
            (self.t_end.abs() / self.dt).ceil().max(1.0) as u64
        } else {
            1000
        }
    }

    /// Every how many steps the run records a sample ([`RunSpec::every`], or about
    /// [`AUTO_SAMPLES`] samples if it is 0).
    pub fn record_every(&self) -> u64 {
        if self.every > 0 {
            self.every
        } else {
            (self.steps() / AUTO_SAMPLES).max(1)
        }
    }

    /// The same run forwards in time, of the reversed field: the end time and the output
    /// times negated.
    pub(crate) fn reversed(&self) -> RunSpec {
        RunSpec {
            t_end: -self.t_end,
            t_eval: self.t_eval.iter().map(|t| -t).collect(),
            ..self.clone()
        }
    }

    /// Checks the numbers: positive finite step, a finite end time other than 0, tolerances
    /// in range, a step count within the budget, gains only for feedback methods.
    pub fn validate(&self) -> Result<(), RunError> {
        let bad = |m: String| Err(RunError::Spec(m));
        if let Method::Symplectic { order } = self.method {
            if ![4, 6, 8].contains(&order) {
                return bad(format!(
                    "symplectic compositions have order 4, 6 or 8, not {order}"
                ));
            }
        }
        let adaptive = self.method.is_adaptive();
        if !(self.dt.is_finite() && (self.dt > 0.0 || (adaptive && self.dt == 0.0))) {
            return bad(format!(
                "step size must be positive and finite, got --dt {}",
                self.dt
            ));
        }
        if !(self.t_end.is_finite() && self.t_end != 0.0) {
            return bad(format!(
                "end time must be finite and not 0 (negative to integrate backwards), got \
                 --t-end {}",
                self.t_end
            ));
        }
        let span = self.t_end.abs();
        if self.dt > span {
            return bad(format!(
                "step size --dt {} exceeds the end time --t-end {}",
                self.dt, self.t_end
            ));
        }
        if !(self.tol.is_finite() && self.tol > 0.0) {
            return bad(format!(
                "projection tolerance must be positive, got --projection-tol {}",
                self.tol
            ));
        }
        if !(self.rtol > 0.0 && self.atol > 0.0 && self.rtol.is_finite() && self.atol.is_finite()) {
            return bad(format!(
                "need positive --rtol and --atol, got {} and {}",
                self.rtol, self.atol
            ));
        }
        self.check_tolerance_floor()?;
        if !(self.max_drift.is_finite() && self.max_drift > 0.0) {
            return bad(format!(
                "--max-drift must be positive and finite, got {}",
                self.max_drift
            ));
        }
        if !adaptive && span / self.dt > self.max_steps as f64 {
            return bad(format!(
                "--t-end {:e} with --dt {} would take {:.3e} steps, more than the limit of {}: \
                 raise it with --max-steps if that is intended",
                self.t_end,
                self.dt,
                span / self.dt,
                self.max_steps
            ));
        }
        let sign = self.t_end.signum();
        if let Some(w) = self.t_eval.windows(2).find(|w| sign * w[0] > sign * w[1]) {
            let order = if sign > 0.0 {
                "increase"
            } else {
                "decrease (a backward run)"
            };
            return bad(format!(
                "--t-eval times must {order}, got {} before {}",
                w[0], w[1]
            ));
        }
        if let Some(t) = self
            .t_eval
            .iter()
            .find(|t| !(sign * **t >= 0.0 && sign * **t <= span))
        {
            return bad(format!(
                "--t-eval time {t} lies outside the run's [0, --t-end {}]",
                self.t_end
            ));
        }
        if !self.method.is_feedback() && self.gains != GainPolicy::Default {
            return Err(RunError::Inapplicable {
                setting: MethodSetting::Gains,
                method: self.method,
            });
        }
        if matches!(self.gains, GainPolicy::Step { .. }) && !adaptive {
            return bad(format!(
                "--gains step follows the step of an adaptive method (feedback-dopri5, \
                 feedback-taylor, split-taylor); `{}` takes fixed steps: use --gains adaptive",
                self.method
            ));
        }
        if matches!(self.gains, GainPolicy::Bounded { .. }) && adaptive {
            return bad(format!(
                "--gains bounded keeps h·k·L inside the stability interval of a fixed step; \
                 `{}` chooses its own steps: use --gains step",
                self.method
            ));
        }
        Ok(())
    }
}

impl RunSpec {
    /// Refuses a tolerance below what the method can meet in f64: `dopri5` and its forms
    /// need rtol ≥ 10 u ([`rtol_floor`]: below it the embedded error estimate is rounding and
    /// the steps shrink until the run crawls), the Taylor methods ε ≥ u²
    /// ([`TOL_FLOOR`](lasalle_runtime::taylor::TOL_FLOOR): the compensated state holds no
    /// more), u = 2⁻⁵³ the unit roundoff. Refused rather than raised: the caller asked for an
    /// accuracy the run cannot give.
    fn check_tolerance_floor(&self) -> Result<(), RunError> {
        if !self.method.is_adaptive() {
            return Ok(());
        }
        let (floor, why) = if self.method.is_taylor() {
            (
                lasalle_runtime::taylor::TOL_FLOOR,
                "u², u = 2⁻⁵³ the unit roundoff: the compensated Taylor state holds no more",
            )
        } else {
            (
                rtol_floor::<f64>(),
                "ten unit roundoffs: below it the error estimate of the embedded pair is \
                 rounding, no step passes it, and the steps shrink until the run crawls",
            )
        };
        // the floor as the message shows it, rounded up: a tolerance copied from it passes
        let shown = round_up(floor);
        if self.rtol < floor {
            return Err(RunError::Spec(format!(
                "--rtol {:e} is below {floor:.3e}, the smallest tolerance `{}` meets in f64 \
                 ({why}): give --rtol {shown} or more",
                self.rtol, self.method
            )));
        }
        if self.method.is_taylor() && self.rtol >= 1.0 {
            return Err(RunError::Spec(format!(
                "--rtol {} is not a tolerance: `{}` needs ε in [{shown}, 1)",
                self.rtol, self.method
            )));
        }
        Ok(())
    }
}

/// `x > 0` rounded up to three significant digits, as `d.dde±n`.
fn round_up(x: f64) -> String {
    let e = x.log10().floor();
    let m = (x / 10f64.powf(e) * 100.0 * (1.0 - 1e-12)).ceil() / 100.0;
    format!("{m:.2}e{e}")
}

/// The preset `name`, or the model's first one if `name` is `None` (`None` if it declares
/// none); an unknown name is an error listing the model's presets.
pub fn find_preset<M>(model: &M, name: Option<&str>) -> Result<Option<&'static Preset>, RunError>
where
    M: lasalle_runtime::Declared<f64, Vec<f64>> + ?Sized,
{
    let presets = model.presets();
    let Some(name) = name else {
        return Ok(presets.first());
    };
    match presets.iter().find(|p| p.name == name) {
        Some(p) => Ok(Some(p)),
        None => {
            let known: Vec<&str> = presets.iter().map(|p| p.name).collect();
            Err(RunError::Model(if known.is_empty() {
                format!("unknown preset `{name}`: the model declares no `run` preset")
            } else {
                format!(
                    "unknown preset `{name}`; the model's presets: {}",
                    known.join(", ")
                )
            }))
        }
    }
}

/// A [`RunSpec`] in the making: a model's run preset (or none) and the caller's overrides,
/// resolved by [`build`](RunSpecBuilder::build) (the spec) or
/// [`prepare`](RunSpecBuilder::prepare) (the spec, the model's parameters and the initial
/// state), whatever order the setters were called in.
///
/// How a preset and overrides combine (as `lasalle run` combines a model's preset and its
/// flags):
///
/// - the method is the override, else the preset's, else `feedback-euler`;
/// - the preset's step and gains apply to its own method, or to any fixed-step one (an
///   adaptive method overriding the preset's picks its own first step, and the step-tracking
///   gains); its end time, sampling, parameters and initial point apply to any method;
/// - a fixed-step method needs a step and every run an end time: without them the spec is
///   [`RunError::Missing`];
/// - the Taylor methods have one tolerance: `rtol` or `atol`, whichever is given (both
///   given and different is an error);
/// - the projection tolerance defaults to the step (to `rtol` for adaptive methods).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunSpecBuilder {
    preset: Option<Preset>,
    method: Option<Method>,
    dt: Option<f64>,
    t_end: Option<f64>,
    gains: Option<GainPolicy>,
    projection_tol: Option<f64>,
    rtol: Option<f64>,
    atol: Option<f64>,
    every: Option<u64>,
    max_steps: Option<u64>,
    max_drift: Option<f64>,
    init: Option<String>,
    params: Vec<(String, Vec<f64>)>,
    t_eval: Option<Vec<f64>>,
    record_events: Option<bool>,
    switching: Option<crate::Switching>,
}

impl RunSpecBuilder {
    /// Output times ([`RunSpec::t_eval`]; [`parse_t_eval`](crate::parse_t_eval) reads
    /// `a:b:n` and lists).
    pub fn t_eval(mut self, times: impl Into<Vec<f64>>) -> Self {
        self.t_eval = Some(times.into());
        self
    }

    /// The solutions of a discontinuous field ([`RunSpec::switching`]; default classical).
    pub fn switching(mut self, sense: crate::Switching) -> Self {
        self.switching = Some(sense);
        self
    }

    /// Whether to locate and record the model's non-terminal events
    /// ([`RunSpec::record_events`]; default `true`).
    pub fn record_events(mut self, record: bool) -> Self {
        self.record_events = Some(record);
        self
    }

    /// The method (default: the preset's, else `feedback-euler`).
    pub fn method(mut self, method: Method) -> Self {
        self.method = Some(method);
        self
    }

    /// The step size, or the first step of an adaptive method.
    pub fn dt(mut self, dt: f64) -> Self {
        self.dt = Some(dt);
        self
    }

    /// The end time.
    pub fn t_end(mut self, t_end: f64) -> Self {
        self.t_end = Some(t_end);
        self
    }

    /// The gains of a feedback method ([`GainPolicy::Default`] keeps the preset's gains).
    pub fn gains(mut self, gains: GainPolicy) -> Self {
        self.gains = Some(gains);
        self
    }

    /// The tolerance of the projection methods on |f(x) − f(x₀)|₂.
    pub fn projection_tol(mut self, tol: f64) -> Self {
        self.projection_tol = Some(tol);
        self
    }

    /// The relative tolerance of adaptive methods (the Taylor methods' tolerance ε).
    pub fn rtol(mut self, rtol: f64) -> Self {
        self.rtol = Some(rtol);
        self
    }

    /// The absolute tolerance of adaptive methods (the Taylor methods' tolerance ε).
    pub fn atol(mut self, atol: f64) -> Self {
        self.atol = Some(atol);
        self
    }

    /// Record every n-th step (0: about [`AUTO_SAMPLES`] samples).
    pub fn every(mut self, every: u64) -> Self {
        self.every = Some(every);
        self
    }

    /// The step budget.
    pub fn max_steps(mut self, max_steps: u64) -> Self {
        self.max_steps = Some(max_steps);
        self
    }

    /// The divergence bound, in multiples of each invariant's scale.
    pub fn max_drift(mut self, max_drift: f64) -> Self {
        self.max_drift = Some(max_drift);
        self
    }

    /// The initial state for [`prepare`](RunSpecBuilder::prepare): a named point of the
    /// model or comma-separated numbers ([`initial_state`]); default: the preset's point,
    /// else the model's first.
    pub fn init(mut self, init: impl Into<String>) -> Self {
        self.init = Some(init.into());
        self
    }

    /// A parameter for [`prepare`](RunSpecBuilder::prepare) to set, after the preset's
    /// (its slot values, as [`Parameters::set_param`] takes them); repeatable.
    pub fn param(mut self, name: impl Into<String>, values: impl Into<Vec<f64>>) -> Self {
        self.params.push((name.into(), values.into()));
        self
    }

    /// The preset, if any.
    pub fn preset(&self) -> Option<&Preset> {
        self.preset.as_ref()
    }

    /// The method the spec will have: the override, else the preset's, else
    /// `feedback-euler`.
    pub fn resolved_method(&self) -> Result<Method, RunError> {
        match (self.method, self.preset.as_ref().and_then(|p| p.method)) {
            (Some(m), _) => Ok(m),
            (None, Some(name)) => name.parse(),
            (None, None) => Ok(Method::Feedback(Base::Euler)),
        }
    }

    /// The spec: the preset's settings under the overrides, validated
    /// ([`RunSpec::validate`]).
    pub fn build(&self) -> Result<RunSpec, RunError> {
        let method = self.resolved_method()?;
        let given = |setting| match setting {
            MethodSetting::Rtol => self.rtol.is_some(),
            MethodSetting::Atol => self.atol.is_some(),
            MethodSetting::Gains => self
                .gains
                .as_ref()
                .is_some_and(|g| *g != GainPolicy::Default),
            MethodSetting::ProjectionTol => self.projection_tol.is_some(),
        };
        if let Some(setting) = MethodSetting::ALL
            .into_iter()
            .find(|s| given(*s) && method.refuses(*s).is_some())
        {
            return Err(RunError::Inapplicable { setting, method });
        }
        let preset = self.preset.as_ref();
        // the preset's step and gains are for its own method, or for any fixed-step one
        let own = preset.filter(|p| {
            !method.is_adaptive() || p.method.map_or(true, |m| m.parse() == Ok(method))
        });
        let dt = match self.dt.or(own.and_then(|p| p.dt)) {
            Some(dt) => dt,
            None if method.is_adaptive() => 0.0,
            None => return Err(RunError::Missing("dt")),
        };
        let t_end = self
            .t_end
            .or(preset.and_then(|p| p.t_end))
            .ok_or(RunError::Missing("t_end"))?;
        let mut spec = RunSpec::new(method, dt, t_end);
        spec.gains = match (
            self.gains.clone().unwrap_or(GainPolicy::Default),
            own.and_then(|p| p.gains),
        ) {
            (GainPolicy::Default, Some(g)) if method.is_feedback() => {
                GainPolicy::Explicit(g.to_vec())
            }
            (policy, _) => policy,
        };
        if method.is_taylor() {
            // Jorba & Zou's one tolerance, absolute below ‖x‖∞ = 1 and relative above
            if let (Some(r), Some(a)) = (self.rtol, self.atol) {
                if r != a {
                    return Err(RunError::Spec(format!(
                        "`{method}` has one tolerance ε (absolute for |x| ≤ 1, relative above): \
                         give --rtol alone, not --rtol {r} with --atol {a}"
                    )));
                }
            }
            spec.rtol = self.rtol.or(self.atol).unwrap_or(spec.rtol);
            spec.atol = spec.rtol;
        } else {
            spec.rtol = self.rtol.unwrap_or(spec.rtol);
            spec.atol = self.atol.unwrap_or(spec.atol);
        }
        spec.tol = self
            .projection_tol
            .unwrap_or(if dt > 0.0 { dt } else { spec.rtol });
        spec.every = self.every.or(preset.and_then(|p| p.every)).unwrap_or(0);
        spec.max_steps = self.max_steps.unwrap_or(spec.max_steps);
        spec.max_drift = self.max_drift.unwrap_or(spec.max_drift);
        spec.t_eval = self.t_eval.clone().unwrap_or_default();
        spec.switching = self.switching.unwrap_or_default();
        spec.record_events = self.record_events.unwrap_or(true);
        spec.validate()?;
        Ok(spec)
    }

    /// Sets the preset's parameters and then the overriding ones on `model`, resolves the
    /// initial state (the override, else the preset's point, else the model's first point)
    /// with those parameters, and builds the spec: what a run of the preset needs.
    pub fn prepare<M>(&self, model: &mut M) -> Result<(RunSpec, Vec<f64>), RunError>
    where
        M: Parameters + ModelInfo + ?Sized,
    {
        let preset = self.preset.as_ref();
        let preset_params = preset.map_or(&[][..], |p| p.params);
        let params = preset_params
            .iter()
            .map(|(name, values)| (*name, *values))
            .chain(self.params.iter().map(|(n, v)| (n.as_str(), v.as_slice())));
        for (name, values) in params {
            model
                .set_param(name, values)
                .map_err(|e| RunError::Model(e.to_string()))?;
        }
        let init = match (&self.init, preset.and_then(|p| p.init)) {
            (Some(init), _) => init.clone(),
            (None, Some(init)) => init.to_string(),
            (None, None) => model
                .point_names()
                .first()
                .map(|n| n.to_string())
                .ok_or_else(|| {
                    RunError::Model("the model has no named point: give --init x1,x2,…".into())
                })?,
        };
        let x0 = initial_state(model, &init)?;
        Ok((self.build()?, x0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PAPER: Preset = Preset {
        name: "paper",
        method: Some("feedback_euler"),
        dt: Some(0.005),
        t_end: Some(70.2481),
        every: None,
        init: Some("paper"),
        gains: Some(&[4.0, 2.0]),
        params: &[],
    };

    #[test]
    fn overrides_win_over_the_preset() {
        let spec = RunSpec::from_preset(Some(&PAPER)).build().unwrap();
        assert_eq!(spec.method, Method::Feedback(Base::Euler));
        assert_eq!((spec.dt, spec.t_end, spec.tol), (0.005, 70.2481, 0.005));
        assert_eq!(spec.gains, GainPolicy::Explicit(vec![4.0, 2.0]));
        let spec = RunSpec::from_preset(Some(&PAPER))
            .t_end(1.0)
            .method(Method::Feedback(Base::Rk4))
            .build()
            .unwrap();
        assert_eq!((spec.dt, spec.t_end), (0.005, 1.0));
        assert_eq!(spec.gains, GainPolicy::Explicit(vec![4.0, 2.0]));
    }

    #[test]
    fn an_adaptive_method_keeps_neither_the_presets_step_nor_its_gains() {
        let spec = RunSpec::from_preset(Some(&PAPER))
            .method("feedback-dopri5".parse().unwrap())
            .build()
            .unwrap();
        assert_eq!((spec.dt, spec.tol), (0.0, 1e-10));
        assert_eq!(spec.gains, GainPolicy::Default);
    }

    #[test]
    fn the_floor_shown_is_rounded_up() {
        assert_eq!(round_up(lasalle_runtime::rtol_floor()), "1.12e-15");
        assert_eq!(round_up(lasalle_runtime::taylor::TOL_FLOOR), "1.24e-32");
        assert_eq!(round_up(2.5e-3), "2.50e-3");
    }

    #[test]
    fn missing_settings_and_the_taylor_tolerance() {
        let b = RunSpec::builder().method(Method::Plain(Base::Rk4));
        assert_eq!(b.clone().t_end(1.0).build(), Err(RunError::Missing("dt")));
        assert_eq!(b.dt(0.1).build(), Err(RunError::Missing("t_end")));
        let taylor = RunSpec::builder()
            .method(Method::Taylor { feedback: false })
            .t_end(1.0);
        let spec = taylor.clone().atol(1e-12).build().unwrap();
        assert_eq!((spec.rtol, spec.atol), (1e-12, 1e-12));
        let e = taylor.rtol(1e-12).atol(1e-10).build().unwrap_err();
        assert!(e.to_string().contains("one tolerance"), "{e}");
    }
}
