import math

import pytest


def test_a_tolerance_below_what_f64_delivers_is_refused(osc):
    # the run that never ended: refused at once, naming the floor
    with pytest.raises(ValueError, match=r"rtol=1e-30 is below 1\.110e-15.*give rtol=1\.12e-15 or more"):
        osc.solve([1.0, 0.0], (0, 1), "dopri5", rtol=1e-30, atol=1e-30)
    with pytest.raises(ValueError, match=r"below 1\.233e-32"):
        osc.solve([1.0, 0.0], (0, 1), "taylor", rtol=1e-33)
    # at the floor the run ends, and meets it
    sol = osc.solve([1.0, 0.0], (0, 1), "dopri5", rtol=1.12e-15, atol=1.12e-15)
    assert sol.success and sol.steps < 5000
    assert abs(sol.y[0, -1] - math.cos(2.0)) < 1e-13


def test_the_step_budget_stops_a_run_that_cannot_reach_its_end(osc):
    sol = osc.solve([1.0, 0.0], (0, 1e300), "dopri5", max_steps=10_000)
    assert not sol.success and sol.failure_kind == "max-steps"
    assert "step budget of 10000 steps spent" in sol.message
