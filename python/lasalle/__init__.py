"""lasalle: structure-preserving simulation of symbolic models.

A model file (``.lsl``) declares a state, parameters, a vector field or a Hamiltonian with its
Poisson structure, and the first integrals and constraints the motion must keep; lasalle
checks every declared integral symbolically, compiles the model to native code in
milliseconds (Cranelift) and integrates it with feedback integrators, projection,
Störmer–Verlet and its compositions, Dormand–Prince or the Taylor method.

>>> import lasalle
>>> m = lasalle.Model("kepler")
>>> sol = m.solve(m.points["paper"], (0, 70.2481), "feedback-rk4", dt=0.005)
>>> sol.success, sol.y.shape[0], bool(sol.max_drift.max() < 1e-6)
(True, 6, True)
"""

from __future__ import annotations

import json
import os
import threading
import warnings
from collections.abc import MutableMapping
from typing import Any, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _lasalle
from ._lasalle import GuardError, LasalleError, ModelError

__all__ = [
    "Model",
    "Solution",
    "Solutions",
    "ModelError",
    "GuardError",
    "LasalleError",
    "normal_form",
    "stability",
    "builtin_models",
    "methods",
]

__version__ = "0.1.0"


def __dir__() -> List[str]:
    """The public names only (``dir(lasalle)``), not the modules and typing names used inside."""
    return sorted(__all__ + ["__version__"])


def builtin_models() -> List[str]:
    """The names of the built-in models (``Model("kepler")``, ``Model("rigid_body")``, …)."""
    return list(_lasalle.builtin_models())


def methods() -> List[str]:
    """Every method name ``solve`` accepts."""
    return _lasalle.known_methods.split(", ")


class Params(MutableMapping):
    """A model's parameters, by name: a float, or an array of the parameter's shape.

    Setting one (``m.params["mu"] = 2.0``) takes effect at the next solve; parameters can be
    changed, not added or removed.
    """

    def __init__(self, native: "_lasalle.NativeModel") -> None:
        self._native = native

    def __getitem__(self, name: str) -> Any:
        if name not in self._native.param_names:
            raise KeyError(name)
        return self._native.get_param(name)

    def __setitem__(self, name: str, value: Any) -> None:
        if name not in self._native.param_names:
            raise KeyError(
                f"unknown parameter {name!r}; the model has: {', '.join(self._native.param_names)}"
            )
        self._native.set_param(name, _param_values(self._native, name, value))

    def __delitem__(self, name: str) -> None:
        raise TypeError("a model's parameters cannot be removed")

    def __iter__(self) -> Iterator[str]:
        return iter(self._native.param_names)

    def __len__(self) -> int:
        return len(self._native.param_names)

    def __repr__(self) -> str:
        return repr(dict(self))


def _param_values(native: "_lasalle.NativeModel", name: str, value: Any) -> List[float]:
    """A parameter value as its flat slots (matrices column-major)."""
    shape = tuple(native.param_shape(name))
    a = np.asarray(value, dtype=float)
    if a.shape != shape and not (shape == () and a.shape == (1,)):
        raise ValueError(f"parameter {name!r} has shape {shape}, got a value of shape {a.shape}")
    return [float(v) for v in np.ravel(a, order="F")]


def _vector(name: str, value: Any, n: int, model: str, names: Sequence[str]) -> np.ndarray:
    try:
        a = np.ascontiguousarray(value, dtype=float)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{name}: not an array of numbers ({e})") from None
    if a.ndim != 1 or a.shape[0] != n:
        raise ValueError(
            f"{name} has shape {a.shape} but the state of {model!r} has dimension {n} "
            f"({', '.join(names)})"
        )
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} is not finite: {a}")
    return a


def _t_span(t_span: Any) -> Tuple[float, float]:
    try:
        t0, t1 = (float(v) for v in t_span)
    except (TypeError, ValueError):
        raise ValueError(f"t_span must be (t0, t1), got {t_span!r}") from None
    if not (np.isfinite(t0) and np.isfinite(t1) and t1 != t0):
        raise ValueError(
            f"t_span must be (t0, t1) with finite t0 != t1 (t1 < t0 integrates backwards), got {t_span!r}"
        )
    return t0, t1


def _check_tol(name: str, v: Optional[float]) -> Optional[float]:
    if v is None:
        return None
    v = float(v)
    if not (np.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be a positive finite number, got {v}")
    return v


def _t_eval(t_eval: Any, t0: float, t1: float) -> Optional[np.ndarray]:
    """The output times, checked: a 1-d array of finite times within ``t_span``, sorted from
    ``t0`` towards ``t1`` (decreasing for a backward run, as scipy's ``solve_ivp``)."""
    if t_eval is None:
        return None
    try:
        a = np.array(t_eval, dtype=float)
    except (TypeError, ValueError) as e:
        raise ValueError(f"t_eval: not an array of numbers ({e})") from None
    if a.ndim != 1 or a.size == 0:
        raise ValueError(f"t_eval must be a 1-d array of times, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError("t_eval is not finite")
    sign = 1.0 if t1 > t0 else -1.0
    if np.any(sign * np.diff(a) < 0):
        i = int(np.argmax(sign * np.diff(a) < 0))
        order = "increasing" if sign > 0 else "decreasing (t1 < t0)"
        raise ValueError(f"t_eval must be sorted in {order} order, got {a[i]} before {a[i + 1]}")
    if sign * (a[0] - t0) < 0 or sign * (a[-1] - t1) > 0:
        raise ValueError(f"t_eval must lie within t_span = ({t0}, {t1}), got times from {a[0]} to {a[-1]}")
    return a


def _run_times(t_eval: Optional[np.ndarray], t0: float, t1: float) -> Optional[List[float]]:
    """The output times from the run's start, clamped to the span [0, t1 - t0] against
    rounding."""
    if t_eval is None:
        return None
    span = t1 - t0
    return [float(v) for v in np.clip(t_eval - t0, min(0.0, span), max(0.0, span))]


def _main_thread() -> bool:
    """Does the caller run on the main thread (where Ctrl-C's KeyboardInterrupt is raised)?"""
    return threading.current_thread() is threading.main_thread()


# the indicators' entries of a row of ``solve_many(…, megno=True)`` or ``fli=True``
_INDICATORS = ("megno", "megno_y", "mle", "fli")

_SUCCESS = "The solver successfully reached the end of the integration interval."


def _terminal_message(stopped: Dict[str, Any]) -> str:
    return f"A termination event occurred: `{stopped['event']}` at t = {stopped['t']!r}."


def _every(every: Optional[int]) -> Optional[int]:
    return None if every is None else _positive_int("every", every)


def _on_grid(d: Dict[str, Any], t_eval: Optional[np.ndarray]) -> None:
    """A run on output times as scipy gives it: the times exactly as asked, and no sample at a
    terminal crossing (it is in ``t_events``)."""
    if t_eval is None:
        return
    k = len(d["t"])
    if d["stopped_by"] is not None:
        k -= 1
    if k < len(d["t"]):
        d["y"] = d["y"][:, :k]
        d["invariants"] = d["invariants"][:, :k]
        d["max_drift"] = d["invariants"].max(axis=1, initial=0.0)
    d["t"] = t_eval[:k].copy()


class Solution:
    """One run, with scipy's ``solve_ivp`` names and shapes plus the invariants.

    Attributes: ``t`` (n_t,), ``y`` (n, n_t), ``success``, ``status`` (0: reached the end,
    1: a terminal event ended the run, -1: stopped by a failure), ``message``, ``nfev``;
    ``t_events`` and ``y_events``: for each event the model declares (``event_names``, in
    declaration order), the times (k,) and states (k, n) of its crossings, a terminal
    crossing included; ``stopped_by``: the terminal event that ended the run (``event``,
    ``t``, ``state``) or None; ``invariants`` (m, n_t): the drift
    ‖fᵢ(x(t)) − fᵢ(x₀)‖ of each declared integral or constraint, in the order of
    ``Model.integrals``; ``max_drift`` (m,) its largest recorded value; ``t_failure``,
    ``y_failure``, ``failure_kind`` (``guard``, ``diverged``, ``blow-up``, ``max-steps``,
    ``step-size``, ``rejections``, ``projection``) and ``guard`` when a failure stopped the run
    (the samples end just before it); ``steps``, ``rejections``, ``gains_initial``,
    ``gains_final``, ``cpu_seconds``, ``wall_seconds``, ``method``, ``counters``;
    ``stability`` (fixed-step feedback methods, else None): ``interval`` (the base method's
    real stability interval β), ``max_h_k_L`` (the largest h·k·L estimate of the run),
    ``left_interval`` (True if some step started with h·k·L > β: the gains were too stiff for
    the step there, and a warning is issued), ``steps_outside``, ``first_outside_t``,
    ``capped_steps`` and ``min_gain_factor`` (default gains: the steps whose gains were scaled
    down, and the smallest factor).

    The variational equations and chaos indicators (``solve(…, variational=True,
    lyapunov_spectrum=True, megno=True, fli=True)``; None unless asked for, and when the run
    itself failed): ``stm`` (n, n), the state-transition matrix Φ(t1) = ∂x(t1)/∂x(t0) by rows;
    ``lyapunov_spectrum`` (n,), the Lyapunov exponents largest first, with
    ``lyapunov_spectrum_qr_order`` (the order of the Gram–Schmidt columns) and
    ``renormalisations``; ``megno`` (⟨Y⟩, MEGNO's mean), ``megno_y`` (Y), ``fli`` (sup ln‖w‖)
    and ``mle`` (ln‖w‖/t); ``extended_runs``: the seconds and steps of each extended run.
    """

    stm: Optional[np.ndarray] = None
    lyapunov_spectrum: Optional[np.ndarray] = None
    lyapunov_spectrum_qr_order: Optional[np.ndarray] = None
    renormalisations: Optional[int] = None
    megno: Optional[float] = None
    megno_y: Optional[float] = None
    fli: Optional[float] = None
    mle: Optional[float] = None
    extended_runs: Optional[Dict[str, Dict[str, float]]] = None

    t: np.ndarray
    y: np.ndarray
    invariants: np.ndarray
    max_drift: np.ndarray
    success: bool
    status: int
    message: str
    nfev: int
    t_events: List[np.ndarray]
    y_events: List[np.ndarray]
    event_names: List[str]
    stopped_by: Optional[Dict[str, Any]]
    stability: Optional[Dict[str, Any]]

    def __init__(
        self,
        d: Dict[str, Any],
        integrals: Sequence[str],
        event_names: Sequence[str] = (),
        t_eval: Optional[np.ndarray] = None,
    ) -> None:
        failure = d.pop("failure")
        _on_grid(d, t_eval)
        self.__dict__.update(d)
        self.integrals = list(integrals)
        self.event_names = list(event_names)
        stability = d.get("stability")
        if stability is not None and stability["left_interval"]:
            warnings.warn(
                f"the feedback gains left the base method's stability interval: h·k·L reached "
                f"{stability['max_h_k_L']:.3e} > {stability['interval']:.4f} in "
                f"{stability['steps_outside']} steps from t = {stability['first_outside_t']}; "
                "the invariants' errors may be larger than the base method's "
                "(use gains='default', smaller gains or a smaller dt)",
                RuntimeWarning,
                stacklevel=3,
            )
        self.status = 0 if failure is None else -1
        if self.stopped_by is not None:
            self.status = 1
        if failure is None:
            self.message = _SUCCESS if self.stopped_by is None else _terminal_message(self.stopped_by)
            self.t_failure = None
            self.y_failure = None
            self.failure_kind = None
            self.guard = None
        else:
            self.message = failure["message"]
            self.t_failure = failure["t"]
            self.y_failure = failure["state"]
            self.failure_kind = failure["kind"]
            self.guard = failure["guard"]

    def raise_for_status(self) -> "Solution":
        """Raises ``GuardError`` if a guard stopped the run, ``LasalleError`` for any other
        failure; returns the solution if it succeeded."""
        if self.success:
            return self
        if self.failure_kind == "guard":
            e = GuardError(self.message)
            e.guard, e.t, e.state = self.guard, self.t_failure, self.y_failure
            raise e
        raise LasalleError(self.message)

    def __repr__(self) -> str:
        drift = ", ".join(f"{n}: {v:.3e}" for n, v in zip(self.integrals, self.max_drift))
        return (
            f"Solution(method={self.method!r}, success={self.success}, n_t={len(self.t)}, "
            f"t_final={self.t[-1]:.6g}, nfev={self.nfev}, max_drift={{{drift}}})"
        )


class Solutions:
    """A batch of runs (``Model.solve_many``), batch-first.

    ``t`` (B, n_t), ``y`` (B, n, n_t), ``invariants`` (B, m, n_t), ``max_drift`` (B, m),
    ``success`` (B,), ``status`` (B,), ``message`` (B,), ``nfev`` (B,), ``steps`` (B,),
    ``t_failure`` (B,) (NaN where a run succeeded). Rows with fewer samples than the longest
    (adaptive methods, failed runs) are padded with NaN; ``n_t`` (B,) holds each row's count.
    Events: ``event_names``; ``t_events[i]`` and ``y_events[i]``, row i's crossings as
    ``Solution`` has them (a list of arrays, one per declared event); ``stopped_by`` (B,) the
    terminal event's name where one ended the row (``status`` 1), else None.
    Indicators (``solve_many(…, megno=True)`` or ``fli=True``): ``megno`` (B,) (⟨Y⟩),
    ``megno_y`` (B,), ``mle`` (B,) and, with ``fli=True``, ``fli`` (B,); NaN where a row failed;
    None without an indicator.
    """

    megno: Optional[np.ndarray] = None
    megno_y: Optional[np.ndarray] = None
    mle: Optional[np.ndarray] = None
    fli: Optional[np.ndarray] = None

    def __init__(
        self,
        rows: List[Any],
        integrals: Sequence[str],
        n: int,
        event_names: Sequence[str] = (),
        t_eval: Optional[np.ndarray] = None,
        indicators: Sequence[str] = (),
    ) -> None:
        self.integrals = list(integrals)
        self.event_names = list(event_names)
        for r in rows:
            if isinstance(r, dict):
                _on_grid(r, t_eval)
        m = len(self.integrals)
        b = len(rows)
        lens = [len(r["t"]) if isinstance(r, dict) else 0 for r in rows]
        nt = max(lens) if lens else 0
        self.n_t = np.array(lens, dtype=np.int64)
        self.t = np.full((b, nt), np.nan)
        self.y = np.full((b, n, nt), np.nan)
        self.invariants = np.full((b, m, nt), np.nan)
        self.max_drift = np.full((b, m), np.nan)
        self.success = np.zeros(b, dtype=bool)
        self.status = np.full(b, -1, dtype=np.int64)
        self.nfev = np.zeros(b, dtype=np.int64)
        self.steps = np.zeros(b, dtype=np.int64)
        self.t_failure = np.full(b, np.nan)
        self.message: List[str] = []
        e = len(self.event_names)
        self.t_events: List[List[np.ndarray]] = []
        self.y_events: List[List[np.ndarray]] = []
        self.stopped_by: List[Optional[str]] = []
        for i, r in enumerate(rows):
            if not isinstance(r, dict):
                # the run could not start (the message says why)
                self.message.append(str(r))
                self.t_events.append([np.empty(0) for _ in range(e)])
                self.y_events.append([np.empty((0, n)) for _ in range(e)])
                self.stopped_by.append(None)
                continue
            self.t_events.append(r["t_events"])
            self.y_events.append(r["y_events"])
            stopped = r["stopped_by"]
            self.stopped_by.append(None if stopped is None else stopped["event"])
            k = lens[i]
            self.t[i, :k] = r["t"]
            self.y[i, :, :k] = r["y"]
            self.invariants[i, :, :k] = r["invariants"]
            self.max_drift[i] = r["max_drift"]
            self.success[i] = r["success"]
            self.nfev[i] = r["nfev"]
            self.steps[i] = r["steps"]
            f = r["failure"]
            if f is None:
                self.status[i] = 0 if stopped is None else 1
                self.message.append(_SUCCESS if stopped is None else _terminal_message(stopped))
            else:
                self.message.append(f["message"])
                if f["t"] is not None:
                    self.t_failure[i] = f["t"]
        for name in indicators:
            values = [r[name] if isinstance(r, dict) else None for r in rows]
            setattr(self, name, np.array([np.nan if v is None else v for v in values], dtype=float))

    @classmethod
    def _concat(cls, parts: List["Solutions"]) -> "Solutions":
        """The rows of `parts` in order, padded to the longest."""
        out = cls.__new__(cls)
        out.integrals = parts[0].integrals
        out.event_names = parts[0].event_names
        nt = max(p.t.shape[1] for p in parts)

        def pad(a: np.ndarray) -> np.ndarray:
            w = [(0, 0)] * (a.ndim - 1) + [(0, nt - a.shape[-1])]
            return np.pad(a, w, constant_values=np.nan)

        out.t = np.concatenate([pad(p.t) for p in parts])
        out.y = np.concatenate([pad(p.y) for p in parts])
        out.invariants = np.concatenate([pad(p.invariants) for p in parts])
        for name in ("n_t", "max_drift", "success", "status", "nfev", "steps", "t_failure"):
            setattr(out, name, np.concatenate([getattr(p, name) for p in parts]))
        for name in ("message", "t_events", "y_events", "stopped_by"):
            setattr(out, name, [v for p in parts for v in getattr(p, name)])
        for name in _INDICATORS:
            if getattr(parts[0], name) is not None:
                setattr(out, name, np.concatenate([getattr(p, name) for p in parts]))
        return out

    def __len__(self) -> int:
        return len(self.success)

    def __repr__(self) -> str:
        return (
            f"Solutions(B={len(self)}, succeeded={int(self.success.sum())}, "
            f"n_t<={self.t.shape[1]}, max_drift<={np.nanmax(self.max_drift) if self.max_drift.size else 0:.3e})"
        )


class Model:
    """A model file, parsed, differentiated, checked and compiled.

    ``Model(path_or_name)`` loads a ``.lsl`` file or a built-in model by name
    (``builtin_models()``); ``Model.from_source(text)`` loads model text. ``backend`` is
    ``"jit"`` (native code, the default) or ``"interpreter"``.

    Attributes: ``name``, ``state_names`` (as ``trace.csv`` names them: ``x[0]``,
    ``R[0,1]``), ``param_names``, ``params`` (a mutable mapping; a change takes effect at the
    next solve), ``integrals`` (the declared integrals and constraints), ``gain_names``,
    ``points`` (name → initial state, with the current parameters), ``presets``, ``source``.

    Models pickle by their source text and parameter values: a worker rebuilds one in
    milliseconds, on any machine.
    """

    def __init__(self, path_or_name: Union[str, "os.PathLike[str]"], *, backend: str = "jit") -> None:
        path, text = _lasalle.model_text(os.fspath(path_or_name))
        self._native = _lasalle.NativeModel(text, path, backend)

    @classmethod
    def from_source(
        cls,
        text: str,
        params: Optional[Mapping[str, Any]] = None,
        backend: str = "jit",
        path: str = "<source>",
    ) -> "Model":
        """A model from its text (``path`` names it in messages), with parameter values."""
        self = cls.__new__(cls)
        self._native = _lasalle.NativeModel(text, path, backend)
        for name, value in (params or {}).items():
            self.params[name] = value
        return self

    def __reduce__(self):
        params = {k: np.array(v) if isinstance(v, np.ndarray) else v for k, v in self.params.items()}
        return (Model.from_source, (self.source, params, self.backend, self.path))

    def __repr__(self) -> str:
        return f"Model({self.name!r}, path={self.path!r}, state={self.state_names}, params={dict(self.params)})"

    # -- description ------------------------------------------------------------------------

    @property
    def name(self) -> str:
        return self._native.name

    @property
    def path(self) -> str:
        return self._native.path

    @property
    def source(self) -> str:
        """The model file's text."""
        return self._native.text

    @property
    def backend(self) -> str:
        return self._native.backend

    @property
    def dim(self) -> int:
        return self._native.dim

    @property
    def state_names(self) -> List[str]:
        return list(self._native.state_names)

    @property
    def param_names(self) -> List[str]:
        return list(self._native.param_names)

    @property
    def params(self) -> Params:
        return Params(self._native)

    @params.setter
    def params(self, values: Mapping[str, Any]) -> None:
        for name, value in values.items():
            self.params[name] = value

    @property
    def integrals(self) -> List[str]:
        return list(self._native.integrals)

    @property
    def gain_names(self) -> List[str]:
        return list(self._native.gain_names)

    @property
    def event_names(self) -> List[str]:
        """The declared events, in declaration order (the order of ``Solution.t_events``)."""
        return list(self._native.event_names)

    @property
    def points(self) -> Dict[str, np.ndarray]:
        return {name: self._native.point(name) for name in self._native.point_names}

    @property
    def presets(self) -> Dict[str, Dict[str, Any]]:
        return self._native.presets()

    @property
    def load_seconds(self) -> float:
        """The time the model took to parse, derive, check and compile."""
        return self._native.load_seconds

    # -- runs -------------------------------------------------------------------------------

    def _y0(self, y0: Any) -> np.ndarray:
        if isinstance(y0, str):
            return self._native.point(y0)
        return _vector("y0", y0, self.dim, self.name, self.state_names)

    def solve(
        self,
        y0: Any,
        t_span: Tuple[float, float],
        method: str = "dopri5",
        *,
        t_eval: Any = None,
        dt: Optional[float] = None,
        rtol: Optional[float] = None,
        atol: Optional[float] = None,
        gains: Union[str, Sequence[float]] = "default",
        params: Optional[Mapping[str, Any]] = None,
        every: Optional[int] = None,
        max_steps: Optional[int] = None,
        max_drift: Optional[float] = None,
        variational: bool = False,
        lyapunov_spectrum: bool = False,
        renormalise_every: Optional[float] = None,
        megno: bool = False,
        fli: bool = False,
    ) -> Solution:
        """Integrates from ``y0`` (the flat state, or a point's name) over ``t_span``.

        ``method``: ``dopri5``, ``rk4``, ``feedback-rk4``, ``projection-euler``,
        ``stormer-verlet-a``, ``symplectic6``, ``taylor``, ``feedback-taylor``,
        ``split-taylor``, … (``methods()``). ``dt``: the step of fixed-step methods (the first
        step of adaptive ones). ``rtol``/``atol``: tolerances of adaptive methods (default
        1e-10; the Taylor methods have one tolerance: give ``rtol``). ``gains``: the gains of
        feedback methods — ``default``, ``model``, ``auto``, ``fixed:c``, ``adaptive:m:c``,
        ``step:c:m`` or the numbers. ``params``: parameter values for this run only.
        ``every``: record every n-th step (default: about 20 000 samples). ``max_steps``: the
        step budget (default 10⁹, rejected steps included); ``max_drift``: an invariant drifting
        past this many times its scale ends the run as diverged. ``t_eval``: the times (from t0
        towards t1, within ``t_span``) to record
        the solution at instead of steps, from each method's continuous extension (adaptive
        methods keep their own steps; ``every`` does not apply).

        ``t_span = (t0, t1)`` with t1 < t0 integrates backwards, with every method that has a
        time-reversed form (all but ``feedback-taylor``, ``split-taylor`` and ``splitting``,
        which raise ``ValueError``); events keep their direction in the model's time.

        The model's events (``event NAME: g = 0 …;``) are located in every run:
        ``t_events``/``y_events`` hold their crossings, one entry per declared event; a
        terminal (``stop``) event ends the run with ``status`` 1.

        A run stopped by a guard, a blow-up or divergence returns ``success=False`` with its
        ``message``, ``t_failure`` and ``y_failure``; an initial state outside the guards
        raises ``GuardError``; bad arguments raise ``ValueError``.

        The variational equations and chaos indicators (docs/chaos.md), each a run of its own
        extended model from ``y0`` with the run's method, tolerances and step budget after the
        run itself (as ``lasalle run --variational --lyapunov-spectrum --megno --fli``, bitwise):
        ``variational=True`` gives ``stm``, Φ(t1) = ∂x(t1)/∂x(t0); ``lyapunov_spectrum=True``
        the exponents (Benettin et al.'s method, re-orthonormalising every
        ``renormalise_every`` time units, default 1); ``megno=True`` MEGNO's ⟨Y⟩ and Y, ``fli=True`` the
        fast Lyapunov indicator (both from one run, with ``mle``). They take ``euler``,
        ``heun``, ``rk4``, ``dopri5`` or ``taylor``, and the indicators and the spectrum a
        forward span; anything else raises ``ValueError`` naming the keyword, and an extended
        run that fails raises ``LasalleError``.
        """
        t0, t1 = _t_span(t_span)
        grid = _t_eval(t_eval, t0, t1)
        if grid is not None and every is not None:
            raise ValueError("every= and t_eval= exclude each other: t_eval gives the output times")
        if renormalise_every is not None and not lyapunov_spectrum:
            raise ValueError("renormalise_every= applies to lyapunov_spectrum=True")
        interval = 1.0 if renormalise_every is None else float(renormalise_every)
        extended = (bool(variational), bool(lyapunov_spectrum), interval, bool(megno), bool(fli))
        asked = any(extended[:2] + extended[3:])
        if asked:
            _lasalle.check_extended(str(method), t0, t1, *extended)
        values = {k: _param_values(self._native, k, v) for k, v in (params or {}).items()}
        d = self._native.solve(
            self._y0(y0),
            t0,
            t1,
            str(method),
            _check_tol("dt", dt),
            _check_tol("rtol", rtol),
            _check_tol("atol", atol),
            gains,
            values,
            _every(every),
            None if max_steps is None else _positive_int("max_steps", max_steps),
            max_drift,
            _run_times(grid, t0, t1),
            _main_thread(),
        )
        sol = Solution(d, self.integrals, self.event_names, grid)
        if asked and sol.status != -1:
            found = _lasalle.solve_extended(
                self._native,
                self._y0(y0),
                t0,
                t1,
                str(method),
                _check_tol("dt", dt),
                _check_tol("rtol", rtol),
                _check_tol("atol", atol),
                gains,
                values,
                None if max_steps is None else _positive_int("max_steps", max_steps),
                max_drift,
                *extended,
                _main_thread(),
            )
            sol.__dict__.update(found)
        return sol

    def solve_many(
        self,
        y0s: Any,
        t_span: Tuple[float, float],
        method: str = "dopri5",
        *,
        params: Optional[Mapping[str, Any]] = None,
        t_eval: Any = None,
        threads: Optional[int] = None,
        lanes: int = 8,
        executor: Any = None,
        shards: Optional[int] = None,
        dt: Optional[float] = None,
        rtol: Optional[float] = None,
        atol: Optional[float] = None,
        gains: Union[str, Sequence[float]] = "default",
        every: Optional[int] = None,
        max_steps: Optional[int] = None,
        max_drift: Optional[float] = None,
        megno: bool = False,
        fli: bool = False,
    ) -> Solutions:
        """Integrates every row of ``y0s`` (B, n), batch-first; each row's result is bitwise
        the one ``solve`` gives it with the same options.

        ``params``: name → values per row, (B,) for a scalar parameter, (B, k) for one of k
        slots, or one value of the parameter's own shape for every row (the other parameters
        keep the model's values). ``threads``: threads in Rust
        (default: one per core), with the GIL released for the whole call; ``lanes``: rows with
        equal parameters integrated together (fixed-step Runge–Kutta methods; 1: each alone).
        ``every``: default records the start and the end only (what lanes need); give it to
        keep intermediate samples. ``executor``: any ``concurrent.futures.Executor`` (a
        process pool, ``dask.distributed.Client.get_executor()``,
        ``mpi4py.futures.MPIPoolExecutor``): the rows go out in ``shards`` shards (default:
        16) of model source, parameters and a row range, and the results are bitwise the
        serial ones. Other options as in ``solve``.

        ``megno=True`` or ``fli=True``: every row is one run of the model extended by the chaos
        indicators' equations (docs/chaos.md), as ``lasalle sweep --indicator megno|fli`` runs
        it, and ``megno``, ``megno_y``, ``mle`` (and with ``fli=True``, whose runs also locate
        the peaks of ln‖w‖, ``fli``) are arrays (B,), each value bitwise the command line's;
        ``y`` holds the model's own components of those runs. Methods and spans as ``solve``'s
        indicators take them.
        """
        t0, t1 = _t_span(t_span)
        grid = _t_eval(t_eval, t0, t1)
        if grid is not None and every is not None:
            raise ValueError("every= and t_eval= exclude each other: t_eval gives the output times")
        y = _states(y0s, self)
        b = y.shape[0]
        cols = _param_columns(self, params, b)
        opts = dict(
            method=str(method),
            dt=_check_tol("dt", dt),
            rtol=_check_tol("rtol", rtol),
            atol=_check_tol("atol", atol),
            gains=gains if isinstance(gains, str) else [float(g) for g in gains],
            every=_every(every) or 2**64 - 1,
            max_steps=None if max_steps is None else _positive_int("max_steps", max_steps),
            max_drift=max_drift,
            t_eval=grid,
            megno=bool(megno),
            fli=bool(fli),
        )
        threads = _threads(threads)
        lanes = _positive_int("lanes", lanes)
        if executor is None:
            return _solve_rows(self, y, (t0, t1), cols, opts, threads, int(lanes))
        return _solve_sharded(self, y, (t0, t1), cols, opts, threads, int(lanes), executor, shards)

    # -- analyses ---------------------------------------------------------------------------


def _positive_int(name: str, v: Any) -> int:
    """``v`` as a whole number ≥ 1, or ``ValueError`` naming the argument ``name``."""
    try:
        whole = int(v) == v and not isinstance(v, bool)
    except (TypeError, ValueError, OverflowError):
        whole = False
    if not whole or not 1 <= v < 2**64:
        raise ValueError(f"{name} must be a whole number ≥ 1 (and below 2⁶⁴), got {v!r}")
    return int(v)


def _threads(threads: Optional[int]) -> int:
    return 0 if threads is None else _positive_int("threads", threads)


def _states(y0s: Any, model: Model) -> np.ndarray:
    try:
        y = np.ascontiguousarray(y0s, dtype=float)
    except (TypeError, ValueError) as e:
        raise ValueError(f"y0s: not an array of numbers ({e})") from None
    if y.ndim != 2 or y.shape[1] != model.dim:
        raise ValueError(
            f"y0s has shape {y.shape} but must be (B, {model.dim}): one state of "
            f"{model.name!r} ({', '.join(model.state_names)}) per row"
        )
    if y.shape[0] == 0:
        raise ValueError("y0s has no rows")
    if not np.all(np.isfinite(y)):
        raise ValueError("y0s is not finite")
    return y


def _param_columns(model: Model, params: Optional[Mapping[str, Any]], b: int) -> Dict[str, np.ndarray]:
    cols = {}
    for name, value in (params or {}).items():
        if name not in model.param_names:
            raise ValueError(
                f"unknown parameter {name!r}; the model {model.name!r} has: {', '.join(model.param_names)}"
            )
        shape = tuple(model._native.param_shape(name))
        k = int(np.prod(shape, dtype=np.int64))
        try:
            a = np.asarray(value, dtype=float)
        except (TypeError, ValueError) as e:
            raise ValueError(f"params[{name!r}]: not an array of numbers ({e})") from None
        if a.shape == shape or (k == 1 and a.ndim == 0):
            # one value for every row
            a = np.broadcast_to(np.ravel(a, order="F"), (b, k))
        elif a.ndim == 1 and k == 1:
            a = a[:, None]
        elif a.ndim == 3:
            # matrices (B, r, c) → column-major slots
            a = np.transpose(a, (0, 2, 1)).reshape(a.shape[0], -1)
        if a.ndim != 2 or a.shape != (b, k):
            raise ValueError(f"params[{name!r}] must have {b} rows of {k} values, got shape {np.shape(value)}")
        cols[name] = np.ascontiguousarray(a)
    return cols


def _solve_rows(model: Model, y: np.ndarray, span, cols, opts, threads: int, lanes: int) -> Solutions:
    if opts["megno"] or opts["fli"]:
        return _solve_rows_indicators(model, y, span, cols, opts, threads, lanes)
    rows = model._native.solve_many(
        y,
        span[0],
        span[1],
        opts["method"],
        opts["dt"],
        opts["rtol"],
        opts["atol"],
        opts["gains"],
        cols,
        opts["every"],
        opts["max_steps"],
        opts["max_drift"],
        _run_times(opts["t_eval"], span[0], span[1]),
        threads,
        lanes,
        _main_thread(),
    )
    return Solutions(rows, model.integrals, model.dim, model.event_names, opts["t_eval"])


def _solve_rows_indicators(model: Model, y: np.ndarray, span, cols, opts, threads: int, lanes: int) -> Solutions:
    """``_solve_rows`` on the model extended by the indicators' equations: the rows' own
    components of the extended runs, with the indicators."""
    rows = _lasalle.solve_many_indicators(
        model._native,
        y,
        span[0],
        span[1],
        opts["method"],
        opts["dt"],
        opts["rtol"],
        opts["atol"],
        opts["gains"],
        cols,
        opts["every"],
        opts["max_steps"],
        opts["max_drift"],
        _run_times(opts["t_eval"], span[0], span[1]),
        threads,
        lanes,
        opts["fli"],
        _main_thread(),
    )
    n = model.dim
    for r in rows:
        if not isinstance(r, dict):
            continue
        r["y"] = r["y"][:n]
        r["y_events"] = [a[:, :n] for a in r["y_events"]]
        if r["stopped_by"] is not None:
            r["stopped_by"]["state"] = r["stopped_by"]["state"][:n]
        if r["failure"] is not None and r["failure"]["state"] is not None:
            r["failure"]["state"] = r["failure"]["state"][:n]
    names = _INDICATORS if opts["fli"] else _INDICATORS[:3]
    return Solutions(rows, model.integrals, n, model.event_names, opts["t_eval"], names)


def _run_shard(source: str, path: str, backend: str, params: Dict[str, Any], y, span, cols, opts, threads, lanes):
    """A shard of ``solve_many`` on a worker: the model rebuilt from its source."""
    model = Model.from_source(source, params, backend, path)
    return _solve_rows(model, y, span, cols, opts, threads, lanes)


def _solve_sharded(model: Model, y, span, cols, opts, threads, lanes, executor, shards) -> Solutions:
    b = y.shape[0]
    shards = 16 if shards is None else int(shards)
    if shards < 1:
        raise ValueError(f"shards must be a positive integer, got {shards!r}")
    bounds = np.linspace(0, b, min(shards, b) + 1).round().astype(int)
    params = {k: (np.array(v) if isinstance(v, np.ndarray) else v) for k, v in model.params.items()}
    futures = [
        executor.submit(
            _run_shard,
            model.source,
            model.path,
            model.backend,
            params,
            y[lo:hi],
            span,
            {k: v[lo:hi] for k, v in cols.items()},
            opts,
            threads,
            lanes,
        )
        for lo, hi in zip(bounds[:-1], bounds[1:])
    ]
    return Solutions._concat([f.result() for f in futures])


def _arrays(value: Any) -> Any:
    """JSON lists of numbers (and of equally long lists of numbers) as arrays."""
    if isinstance(value, dict):
        return {k: _arrays(v) for k, v in value.items()}
    if isinstance(value, list):
        if value and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
            return np.array(value, dtype=float)
        items = [_arrays(v) for v in value]
        if (
            items
            and all(isinstance(v, np.ndarray) and v.ndim == 1 for v in items)
            and len({v.shape for v in items}) == 1
        ):
            return np.stack(items)
        return items
    return value


def normal_form(
    model: Union[Model, str],
    order: int = 12,
    precision: str = "dd",
    params: Optional[Mapping[str, float]] = None,
    *,
    at: Union[str, Sequence[float], None] = None,
    resonant: bool = False,
    resonance_tol: float = 1e-6,
    max_rel_error: float = 1e-3,
    error_estimate: str = "cheap",
) -> Dict[str, Any]:
    """The Birkhoff normal form of a Hamiltonian model at an elliptic equilibrium: what
    ``lasalle normal-form --format json`` prints, as dicts with arrays for the number lists.

    ``precision``: ``dd`` (double-double), ``f64``, or ``auto`` (f64, redone in double-double
    when a coefficient's estimated error exceeds ``max_rel_error``). ``params`` override the
    model's scalar parameters; ``at`` is the equilibrium (a point's name or a Newton start,
    default the model's first point). A resonance, a non-elliptic equilibrium or lost
    precision raise ``ValueError`` with the reason.
    """
    _positive_int("order", order)
    for name, v in (("resonance_tol", resonance_tol), ("max_rel_error", max_rel_error)):
        _check_tol(name, v)
    if not isinstance(model, Model):
        model = Model(model)
    text = model._native.normal_form(
        int(order),
        str(precision),
        {k: float(v) for k, v in (params or {}).items()},
        at,
        bool(resonant),
        float(resonance_tol),
        float(max_rel_error),
        str(error_estimate),
    )
    return _arrays(json.loads(text))


def stability(
    model: Union[Model, str],
    *,
    params: Optional[Mapping[str, Any]] = None,
    at: Optional[Sequence[float]] = None,
    casimir: Optional[float] = None,
    range: Optional[Tuple[float, float]] = None,
    levels: int = 121,
    lyapunov: Optional[str] = None,
    radius: Optional[float] = None,
    time_bound: Optional[Sequence[Tuple[float, float]]] = None,
    order: Optional[int] = None,
    for_time: Optional[Sequence[float]] = None,
    outer_ratio: Optional[float] = None,
    remainder_degree: Optional[int] = None,
    metric: str = "euclidean",
    equilibrium: Union[str, Sequence[float], None] = None,
    validate: bool = False,
    horizon: float = 200.0,
    certified: bool = False,
) -> Dict[str, Any]:
    """The stability analysis the model's structure chooses: what ``lasalle stability
    --format json`` prints, as dicts with arrays for the number lists.

    - Lie–Poisson models on so(3)*: the equilibria on the Casimir level ``casimir`` (default:
      |P| of the model's first point) or at the point ``at`` (P1, P2, P3), and the branches of
      equilibria over ``range`` = (a, b) of levels (``levels`` of them);
    - canonical Hamiltonian models: the normal-form verdict at ``equilibrium`` (a point's name
      or a Newton start; default the first point) and, for each ``time_bound`` (d0, d1), the
      time before an orbit from within d0 can reach d1 (orders up to ``order``, else the
      optimal order is searched); ``for_time``, ``outer_ratio``, ``remainder_degree``,
      ``metric`` (``euclidean`` or ``linear-normal``), ``validate`` (integrate orbits to
      ``horizon``) and ``certified`` (a certified time next to each estimate, by interval
      arithmetic: slow, tens of seconds per tube) as the command's flags;
    - models without Hamiltonian structure (planar, dissipative): the domain of attraction of
      the equilibrium ``at`` (x1, x2; default the first named asymptotically stable one), with
      the model's ``let`` ``lyapunov`` (default ``energy``) and the search ``radius``.

    ``params`` override the model's parameters for this analysis. A setting of another
    analysis than the model's, or one out of range, raises ``ValueError``; so does an analysis
    that cannot run (with the reason).
    """
    if not isinstance(model, Model):
        model = Model(model)
    if params:
        values = {k: (np.array(v) if isinstance(v, np.ndarray) else v) for k, v in model.params.items()}
        values.update(params)
        model = Model.from_source(model.source, values, model.backend, model.path)

    def numbers(name: str, v: Any) -> Optional[List[float]]:
        if v is None:
            return None
        try:
            a = np.asarray(v, dtype=float).ravel()
        except (TypeError, ValueError):
            raise ValueError(f"{name}: not a sequence of numbers: {v!r}") from None
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name}: not finite: {v!r}")
        return [float(x) for x in a]

    tubes = []
    for tb in time_bound or []:
        t = numbers("time_bound", tb)
        if len(t) != 2:
            raise ValueError(f"time_bound: pairs (d0, d1), got {tb!r}")
        tubes.append((t[0], t[1]))
    span = None
    if range is not None:
        r = numbers("range", range)
        if len(r) != 2:
            raise ValueError(f"range: (a, b) with 0 < a < b, got {range!r}")
        span = (r[0], r[1])
    if int(levels) != levels or levels < 1:
        raise ValueError(f"levels must be a positive integer, got {levels!r}")
    for name, v in (("order", order), ("remainder_degree", remainder_degree)):
        if v is not None:
            _positive_int(name, v)
    text = model._native.stability(
        os.path.splitext(os.path.basename(model.path))[0],
        None if casimir is None else float(casimir),
        numbers("at", at),
        span,
        int(levels),
        lyapunov,
        None if radius is None else float(radius),
        tubes,
        None if order is None else int(order),
        numbers("for_time", for_time) or [],
        None if outer_ratio is None else float(outer_ratio),
        None if remainder_degree is None else int(remainder_degree),
        str(metric),
        equilibrium,
        bool(validate),
        float(horizon),
        bool(certified),
    )
    return _arrays(json.loads(text))
