import numpy as np
import pytest

import lasalle

# Kepler's orbit from the paper's point: e = 0.8, a = 5 (energy -1/10), period T = 2π a^{3/2}
T = 2 * np.pi * 5**1.5


def test_shapes_and_names_follow_scipy(kepler):
    sol = kepler.solve("paper", (0, 10), "feedback-rk4", dt=0.01, every=10)
    nt = 101
    assert sol.t.shape == (nt,) and sol.y.shape == (6, nt)
    assert sol.invariants.shape == (2, nt) and sol.max_drift.shape == (2,)
    assert sol.success and sol.status == 0 and sol.t_failure is None
    assert sol.nfev == 4 * 1000 and sol.steps == 1000
    np.testing.assert_allclose(sol.t, np.linspace(0, 10, nt), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(sol.max_drift, sol.invariants.max(axis=1))
    assert sol.invariants[:, 0].tolist() == [0, 0]


def test_the_oscillator_against_its_closed_form(osc):
    # q = cos 2t, p = -2 sin 2t
    t1 = 3.0
    for method, opts, tol in [
        ("dopri5", dict(rtol=1e-12, atol=1e-12), 1e-9),
        ("taylor", dict(rtol=1e-15), 1e-12),
        ("rk4", dict(dt=1e-3), 1e-10),
        ("symplectic6", dict(dt=1e-2), 1e-9),
        ("feedback-rk4", dict(dt=1e-3), 1e-10),
    ]:
        sol = osc.solve([1.0, 0.0], (0, t1), method, **opts)
        assert sol.success, (method, sol.message)
        np.testing.assert_allclose(sol.y[:, -1], [np.cos(2 * t1), -2 * np.sin(2 * t1)], atol=tol, err_msg=method)
        assert sol.t[-1] == pytest.approx(t1, abs=1e-12)


def test_a_time_span_not_starting_at_zero_shifts_the_times(osc):
    a = osc.solve([1.0, 0.0], (0, 1), "rk4", dt=1e-3)
    b = osc.solve([1.0, 0.0], (5, 6), "rk4", dt=1e-3)
    assert np.array_equal(a.y, b.y)
    np.testing.assert_allclose(b.t, a.t + 5, rtol=0, atol=1e-12)


def test_kepler_returns_after_one_period_and_feedback_keeps_the_integrals(kepler):
    y0 = kepler.points["paper"]
    sol = kepler.solve(y0, (0, T), "taylor", rtol=1e-15)
    np.testing.assert_allclose(sol.y[:, -1], y0, atol=1e-9)
    # the paper's run (§4.2): feedback-Euler keeps L and A 20 times better than Euler
    plain = kepler.solve(y0, (0, T), "euler", dt=0.005)
    fb = kepler.solve(y0, (0, T), "feedback-euler", dt=0.005)
    assert np.all(fb.max_drift < plain.max_drift / 20)
    assert fb.gains_initial == [4.0, 2.0]


def test_a_guard_stops_the_run_with_its_time_and_state(kepler):
    # from aphelion at r = 1, e = 0.91: perihelion r = 0.047 at t = 1.19, where a step of
    # 0.05 moves farther than the distance to the centre and the `resolved` guard fails
    sol = kepler.solve([1, 0, 0, 0, 0.3, 0], (0, 3), "rk4", dt=0.05)
    assert not sol.success and sol.status == -1
    assert sol.failure_kind == "guard" and sol.guard == "resolved"
    assert 1.0 < sol.t_failure < 1.25 and sol.y_failure.shape == (6,)
    assert 0.05 * np.linalg.norm(sol.y_failure[3:]) > np.linalg.norm(sol.y_failure[:3])
    assert "resolved" in sol.message
    assert sol.t[-1] < sol.t_failure
    with pytest.raises(lasalle.GuardError) as info:
        sol.raise_for_status()
    assert info.value.guard == "resolved" and info.value.t == sol.t_failure


def test_an_initial_state_outside_the_domain_is_a_guard_error(kepler):
    with pytest.raises(lasalle.GuardError) as info:
        kepler.solve([0, 0, 0, 0, 1, 0], (0, 1), "dopri5")
    assert info.value.guard == "collision" and info.value.t == 0.0
    np.testing.assert_array_equal(info.value.state, [0, 0, 0, 0, 1, 0])


def test_a_blow_up_is_a_failed_solution():
    # x' = x²: x = 1/(1 - t) from x = 1 blows up at t = 1
    m = lasalle.Model.from_source("model Blow { state x: scalar; d/dt x = x^2; point one { x = 1; } }")
    sol = m.solve("one", (0, 2), "dopri5", rtol=1e-8, atol=1e-8)
    assert not sol.success and sol.failure_kind in ("blow-up", "step-size", "rejections")
    assert 0.9 < sol.t_failure <= 1.0 + 1e-6
    with pytest.raises(lasalle.LasalleError):
        sol.raise_for_status()


def test_a_diverged_run_is_a_failed_solution(osc):
    # explicit Euler multiplies the oscillator's energy by 1 + (h w)² = 1.04 a step: past
    # 1000 × E(0) = 2000 after ln(1001)/ln(1.04) = 176.1 steps, at step 177
    sol = osc.solve("start", (0, 100), "euler", dt=0.1)
    assert not sol.success and sol.failure_kind == "diverged", sol.message
    assert sol.t_failure == pytest.approx(17.7)
    assert sol.t[-1] < sol.t_failure


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(method="nope"), "unknown method `nope`"),
        (dict(method="rk4"), "fixed steps: give dt="),
        (dict(method="rk4", dt=-1.0), "dt"),
        (dict(method="rk4", dt=2.0), "exceeds the span"),
        (dict(method="dopri5", rtol=0.0), "rtol"),
        (dict(method="taylor", rtol=1e-12, atol=1e-10), "one tolerance"),
        (dict(method="dopri5", gains=[1.0, 2.0]), "applies to feedback methods"),
        (dict(method="rk4", dt=0.01, rtol=1e-8), "rtol= applies to adaptive methods"),
        (dict(method="rk4", dt=0.01, atol=1e-8), "atol= applies to adaptive methods"),
        (dict(method="symplectic6", dt=0.01, rtol=1e-8), "`symplectic6` takes fixed steps"),
        (dict(method="feedback-rk4", dt=0.1, gains=[1.0]), "gains"),
        (dict(method="feedback-rk4", dt=0.1, gains="nope"), "gains"),
        (dict(method="stormer-verlet-a", dt=0.1, params={"nope": 1.0}), "unknown parameter"),
        (dict(method="splitting", dt=0.1), "splitting rigid_body"),
        (dict(method="rk4", dt=0.1, every=0), "every"),
    ],
)
def test_bad_arguments_are_value_errors(kepler, kwargs, match):
    with pytest.raises(ValueError, match=match):
        kepler.solve("paper", (0, 1), **kwargs)


def test_bad_states_and_spans_are_value_errors(kepler):
    with pytest.raises(ValueError, match="dimension 6"):
        kepler.solve([1, 0, 0], (0, 1))
    with pytest.raises(ValueError, match="finite"):
        kepler.solve([np.nan, 0, 0, 0, 1, 0], (0, 1))
    with pytest.raises(ValueError, match="t_span"):
        kepler.solve("paper", (1, 1))
    with pytest.raises(ValueError, match="unknown point"):
        kepler.solve("aphelion", (0, 1))


def test_taylor_runs_reuse_their_kernels_with_the_bits_of_new_ones(kepler):
    # the second run takes the first run's kernels (built once per model and order)
    y0 = [1.0, 0, 0, 0, 1.2, 0]
    first = kepler.solve(y0, (0, 20), "feedback-taylor", rtol=1e-14)
    kepler.params["mu"] = 0.9
    changed = kepler.solve(y0, (0, 20), "feedback-taylor", rtol=1e-14)
    fresh = lasalle.Model("kepler")
    fresh.params["mu"] = 0.9
    assert np.array_equal(changed.y, fresh.solve(y0, (0, 20), "feedback-taylor", rtol=1e-14).y)
    kepler.params["mu"] = 1.0
    assert np.array_equal(first.y, kepler.solve(y0, (0, 20), "feedback-taylor", rtol=1e-14).y)
    assert not np.array_equal(first.y, changed.y)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(method="rk4", dt=2.0), "step size dt=2 exceeds the span t1 - t0 = 1"),
        (dict(method="rk4", dt=1e-3, max_steps=10), "raise it with max_steps= if that is intended"),
        (dict(method="rk4", dt=1e-3, max_steps=10), "the span t1 - t0 = 1e0 with dt=0.001 would take"),
        (dict(method="taylor", rtol=1e-12, atol=1e-10), "give rtol= alone, not rtol=0.000000000001 with atol=0.0000000001"),
        (dict(method="dopri5", gains=[1.0, 2.0]), "gains= applies to feedback methods (feedback-*, feedback-taylor, split-taylor), not to `dopri5`"),
        (dict(method="rk4", dt=0.1, rtol=1e-8), "rtol= applies to adaptive methods"),
        (dict(method="feedback-rk4", dt=0.1, gains="step:1:10"), 'use gains="adaptive:m:c"'),
        (dict(method="rk4", dt=0.1, max_drift=-1.0), "max_drift= must be positive and finite, got -1"),
    ],
)
def test_errors_name_pythons_keywords_not_the_command_lines_flags(kepler, kwargs, message):
    with pytest.raises(ValueError) as info:
        kepler.solve("paper", (0, 1), **kwargs)
    assert message in str(info.value) and "--" not in str(info.value), str(info.value)
    with pytest.raises(ValueError) as info:
        kepler.solve_many(np.tile(kepler.points["paper"], (2, 1)), (0, 1), **kwargs)
    assert message in str(info.value) and "--" not in str(info.value), str(info.value)


# a field without integrals: nothing for feedback to keep
DAMPED = """model Damped {
    state q: scalar, p: scalar;
    d/dt q = p;
    d/dt p = -q - p / 10;
    point start { q = 1; p = 0; }
}
"""


@pytest.mark.parametrize("method, opts", [("feedback-rk4", dict(dt=0.01)), ("feedback-taylor", {})])
def test_feedback_on_a_model_without_integrals_is_refused(method, opts):
    m = lasalle.Model.from_source(DAMPED, path="damped.lsl")
    with pytest.raises(ValueError, match="declares none: use a method without feedback"):
        m.solve("start", (0, 1), method, **opts)
    assert m.solve("start", (0, 1), method.removeprefix("feedback-"), **opts).success


def test_the_package_lists_its_public_names_only():
    names = dir(lasalle)
    assert set(names) == set(lasalle.__all__) | {"__version__"}
    assert "Any" not in names and "json" not in names and "np" not in names


@pytest.mark.parametrize(
    "method, opts, tol",
    [
        ("dopri5", dict(rtol=1e-12, atol=1e-12), 1e-9),
        ("taylor", dict(rtol=1e-15), 1e-12),
        ("rk4", dict(dt=1e-3), 1e-10),
        ("symplectic6", dict(dt=1e-2), 1e-9),
        ("feedback-dopri5", dict(rtol=1e-12, atol=1e-12), 1e-9),
    ],
)
def test_a_backward_span_integrates_backwards(osc, method, opts, tol):
    # from (cos 2·3, -2 sin 2·3) at t = 3 back to t = 0: q = cos 2t, p = -2 sin 2t
    t0 = 3.0
    y0 = [np.cos(2 * t0), -2 * np.sin(2 * t0)]
    grid = np.linspace(t0, 0.0, 7)
    sol = osc.solve(y0, (t0, 0.0), method, t_eval=grid, **opts)
    assert sol.success, sol.message
    np.testing.assert_array_equal(sol.t, grid)
    np.testing.assert_allclose(sol.y[0], np.cos(2 * grid), rtol=0, atol=tol)
    np.testing.assert_allclose(sol.y[1], -2 * np.sin(2 * grid), rtol=0, atol=tol)


def test_backwards_then_forwards_returns_to_the_start(kepler):
    there = kepler.solve("paper", (0, 10), "taylor", rtol=1e-15)
    back = kepler.solve(there.y[:, -1], (10, 0), "taylor", rtol=1e-15)
    assert back.t[0] == 10 and back.t[-1] == 0 and np.all(np.diff(back.t) < 0)
    np.testing.assert_allclose(back.y[:, -1], kepler.points["paper"], rtol=0, atol=1e-11)


@pytest.mark.parametrize("method", ["feedback-taylor", "split-taylor"])
def test_methods_without_a_reversed_form_refuse_backward_spans(kepler, method):
    with pytest.raises(ValueError, match="cannot integrate backwards"):
        kepler.solve("paper", (1, 0), method)
    with pytest.raises(ValueError, match="decreasing"):
        kepler.solve("paper", (1, 0), "rk4", dt=0.1, t_eval=[0.0, 1.0])
