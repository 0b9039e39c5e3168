"""Output times (t_eval) and the model's events, scipy's way, against closed forms."""

import concurrent.futures

import numpy as np
import pytest

import lasalle

# Kepler (μ = 1) with a = 1, e = 1/2 from pericentre: r_p = 1/2, v_p = √3, period 2π
E = 0.5
PERICENTRE = np.array([1 - E, 0, 0, 0, np.sqrt((1 + E) / (1 - E)), 0])
# r = a (1 - e cos u) = 6/5 on the way out: cos u = -2/5; the time is Kepler's M = u - e sin u
U_STOP = np.arccos(-0.4)
T_STOP = U_STOP - E * np.sin(U_STOP)


def kepler_with(events: str) -> lasalle.Model:
    """The built-in Kepler model with `events` declared (before its guards)."""
    source = lasalle.Model("kepler").source.replace("    guard collision", events + "\n    guard collision")
    assert events in source
    return lasalle.Model.from_source(source, path="kepler_events.lsl")


@pytest.fixture(scope="module")
def passages():
    return kepler_with(
        "    event pericentre: dot(x, v) = 0 rising;\n    event apocentre: dot(x, v) = 0 falling;"
    )


@pytest.fixture(scope="module")
def escape():
    return kepler_with("    event pericentre: dot(x, v) = 0 rising;\n    event far: norm(x) - 1.2 = 0 rising stop;")


def kepler_position(t):
    """The position at times t from pericentre, from Kepler's equation (Newton, in numpy)."""
    u = np.array(t, dtype=float)
    for _ in range(50):
        u = u - (u - E * np.sin(u) - t) / (1 - E * np.cos(u))
    return np.stack([np.cos(u) - E, np.sqrt(1 - E**2) * np.sin(u), np.zeros_like(u)])


def test_pericentre_and_apocentre_passages_at_the_period(passages):
    assert passages.event_names == ["pericentre", "apocentre"]
    n = 20
    sol = passages.solve(PERICENTRE, (0, 2 * np.pi * n + 1), "taylor", rtol=1e-15)
    assert sol.success and sol.status == 0 and sol.stopped_by is None
    peri, apo = sol.t_events
    # a zero at the initial time is no crossing: the k-th pericentre passage is at 2πk
    assert peri.shape == (n,) and apo.shape == (n,)
    np.testing.assert_allclose(peri, 2 * np.pi * np.arange(1, n + 1), rtol=0, atol=1e-10)
    np.testing.assert_allclose(apo[:n], np.pi + 2 * np.pi * np.arange(n), rtol=0, atol=1e-10)
    assert sol.y_events[0].shape == (n, 6) and sol.y_events[1].shape == (len(apo), 6)
    np.testing.assert_allclose(sol.y_events[0], np.tile(PERICENTRE, (n, 1)), rtol=0, atol=1e-9)
    # at apocentre r = 3/2 and v = 1/√3
    np.testing.assert_allclose(np.linalg.norm(sol.y_events[1][:, :3], axis=1), 1.5, rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(sol.y_events[1][:, 3:], axis=1), 1 / np.sqrt(3), rtol=0, atol=1e-9)


def test_events_with_a_fixed_step_method_and_a_shifted_span(passages):
    # RK4 with h = 1e-3 keeps the phase to ~1e-10 a period; the crossings on the Hermite cubic
    a = passages.solve(PERICENTRE, (0, 13), "rk4", dt=1e-3)
    b = passages.solve(PERICENTRE, (100, 113), "rk4", dt=1e-3)
    np.testing.assert_allclose(a.t_events[0], [2 * np.pi, 4 * np.pi], rtol=0, atol=1e-8)
    np.testing.assert_allclose(a.t_events[1], [np.pi, 3 * np.pi], rtol=0, atol=1e-8)
    np.testing.assert_allclose(b.t_events[0], a.t_events[0] + 100, rtol=0, atol=1e-12)
    assert np.array_equal(a.y_events[0], b.y_events[0])


def test_a_terminal_event_ends_the_run_with_status_1(escape):
    assert escape.event_names == ["pericentre", "far"]
    sol = escape.solve(PERICENTRE, (0, 10), "dopri5", rtol=1e-13, atol=1e-13)
    assert sol.success and sol.status == 1, sol.message
    assert "termination event" in sol.message and "`far`" in sol.message
    assert sol.stopped_by["event"] == "far"
    assert sol.t_events[0].shape == (0,) and sol.t_events[1].shape == (1,)
    assert sol.t_events[1][0] == pytest.approx(T_STOP, abs=1e-10)
    assert np.linalg.norm(sol.y_events[1][0, :3]) == pytest.approx(1.2, abs=1e-10)
    # without t_eval the last sample is the crossing, as in scipy
    assert sol.t[-1] == sol.t_events[1][0] and np.array_equal(sol.y[:, -1], sol.y_events[1][0])
    # with t_eval the samples stop at the last output time before it
    grid = np.linspace(0, 10, 101)
    on = escape.solve(PERICENTRE, (0, 10), "dopri5", rtol=1e-13, atol=1e-13, t_eval=grid)
    assert on.status == 1 and np.array_equal(on.t, grid[grid <= T_STOP])
    assert on.t_events[1][0] == sol.t_events[1][0]


def test_t_eval_against_keplers_equation(passages):
    grid = np.linspace(0, 4 * np.pi, 97)
    for method, opts, tol in [
        ("taylor", dict(rtol=1e-15), 1e-11),
        ("dopri5", dict(rtol=1e-13, atol=1e-13), 1e-9),
        ("rk4", dict(dt=1e-3), 1e-8),
        ("feedback-rk4", dict(dt=1e-3), 1e-8),
        ("symplectic6", dict(dt=1e-2), 1e-7),
    ]:
        sol = passages.solve(PERICENTRE, (0, grid[-1]), method, t_eval=grid, **opts)
        assert sol.success, (method, sol.message)
        assert np.array_equal(sol.t, grid) and sol.y.shape == (6, 97) and sol.invariants.shape == (2, 97)
        np.testing.assert_allclose(sol.y[:3], kepler_position(grid), rtol=0, atol=tol, err_msg=method)


def test_t_eval_keeps_the_adaptive_steps_and_the_oscillator_closed_form(osc):
    # q = cos 2t, p = -2 sin 2t; the grid starts after t0 (a run without events ends at the
    # grid's last time: here t1)
    grid = 5 + np.linspace(0.1, 3.0, 59)
    free = osc.solve([1.0, 0.0], (5, 8), "dopri5", rtol=1e-12, atol=1e-12)
    sol = osc.solve([1.0, 0.0], (5, 8), "dopri5", rtol=1e-12, atol=1e-12, t_eval=grid)
    assert np.array_equal(sol.t, grid)
    assert sol.steps == free.steps and sol.nfev >= free.nfev
    s = grid - 5
    np.testing.assert_allclose(sol.y, [np.cos(2 * s), -2 * np.sin(2 * s)], rtol=0, atol=1e-9)


def test_solve_many_rows_are_their_lone_solves_with_events_and_t_eval(passages, escape):
    rng = np.random.default_rng(3)
    y0s = np.tile(PERICENTRE, (12, 1))
    y0s[:, 4] *= rng.uniform(0.99, 1.01, 12)  # periods < 9, apocentres > 1.2
    grid = np.linspace(0, 9, 31)
    for model, method, opts in [
        (passages, "rk4", dict(dt=0.01)),
        (passages, "feedback-rk4", dict(dt=0.01)),
        (passages, "dopri5", dict(rtol=1e-10, atol=1e-10)),
        (escape, "taylor", dict(rtol=1e-13)),
    ]:
        for t_eval in (None, grid):
            many = model.solve_many(y0s, (0, 9), method, t_eval=t_eval, threads=2, **opts)
            assert many.event_names == model.event_names
            for i in range(len(y0s)):
                if t_eval is None:
                    lone = model.solve(y0s[i], (0, 9), method, every=2**64 - 1, **opts)
                else:
                    lone = model.solve(y0s[i], (0, 9), method, t_eval=t_eval, **opts)
                k = many.n_t[i]
                assert np.array_equal(many.t[i, :k], lone.t) and np.array_equal(many.y[i, :, :k], lone.y)
                assert many.status[i] == lone.status and many.stopped_by[i] == (lone.stopped_by or {}).get("event")
                for a, b in zip(many.t_events[i], lone.t_events):
                    assert np.array_equal(a, b), (method, i)
                for a, b in zip(many.y_events[i], lone.y_events):
                    assert np.array_equal(a, b), (method, i)
            if model is escape:
                assert (many.status == 1).all() and many.stopped_by == ["far"] * 12
            else:
                assert all(len(te[0]) == 1 for te in many.t_events)


def test_an_executor_keeps_the_events(escape):
    y0s = np.tile(PERICENTRE, (6, 1))
    y0s[:, 4] *= np.linspace(0.99, 1.01, 6)
    serial = escape.solve_many(y0s, (0, 5), "dopri5", rtol=1e-10, atol=1e-10)
    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        sharded = escape.solve_many(y0s, (0, 5), "dopri5", rtol=1e-10, atol=1e-10, executor=pool, shards=3)
    assert sharded.stopped_by == serial.stopped_by == ["far"] * 6
    assert all(np.array_equal(a[1], b[1]) for a, b in zip(serial.t_events, sharded.t_events))


@pytest.mark.parametrize(
    "t_eval, match",
    [
        ([0.5, 0.2], "increasing"),
        ([0.0, 2.0], "within t_span"),
        ([[0.1, 0.2]], "1-d"),
        ([0.1, np.nan], "finite"),
    ],
)
def test_bad_output_times_are_value_errors(osc, t_eval, match):
    with pytest.raises(ValueError, match=match):
        osc.solve([1.0, 0.0], (0, 1), "rk4", dt=0.01, t_eval=t_eval)
    with pytest.raises(ValueError, match=match):
        osc.solve_many([[1.0, 0.0]], (0, 1), "rk4", dt=0.01, t_eval=t_eval)


def test_every_and_t_eval_exclude_each_other(osc):
    with pytest.raises(ValueError, match="exclude each other"):
        osc.solve([1.0, 0.0], (0, 1), "rk4", dt=0.01, every=2, t_eval=[0.5])
