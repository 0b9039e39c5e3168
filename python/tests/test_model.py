import pickle

import numpy as np
import pytest

import lasalle
from conftest import OSCILLATOR, ROOT


def test_a_builtin_model_and_its_file_are_the_same_model(kepler):
    by_path = lasalle.Model(ROOT / "models" / "kepler.lsl")
    assert kepler.name == by_path.name == "Kepler"
    assert kepler.source == by_path.source
    assert kepler.state_names == ["x[0]", "x[1]", "x[2]", "v[0]", "v[1]", "v[2]"]
    assert kepler.param_names == ["mu"]
    assert kepler.integrals == ["L", "A"]
    assert kepler.gain_names == ["k1", "k2"]
    np.testing.assert_array_equal(kepler.points["paper"], [1, 0, 0, 0, np.sqrt(1.8), 0])
    paper = kepler.presets["paper"]
    assert paper["method"] == "feedback-euler" and paper["dt"] == 0.005 and paper["t_end"] == 70.2481
    assert "kepler" in lasalle.builtin_models()


def test_matrix_states_are_named_as_in_trace_csv():
    rb = lasalle.Model("rigid_body")
    assert "R[0,1]" in rb.state_names and "R[1,0]" in rb.state_names
    # column-major: R[1,0] comes before R[0,1]
    assert rb.state_names.index("R[1,0]") < rb.state_names.index("R[0,1]")


def test_setting_a_parameter_takes_effect_at_the_next_solve(osc):
    assert osc.params["w"] == 2.0
    # E = w²/2 at (1, 0): the point's energy follows w
    sol = osc.solve("start", (0, np.pi), "dopri5", rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(sol.y[:, -1], [1, 0], atol=1e-9)  # period π at w = 2
    osc.params["w"] = 1.0
    assert osc.params["w"] == 1.0
    sol = osc.solve("start", (0, np.pi), "dopri5", rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(sol.y[:, -1], [-1, 0], atol=1e-9)  # half a period at w = 1
    with pytest.raises(KeyError):
        osc.params["nope"] = 1.0
    with pytest.raises(ValueError, match="shape"):
        osc.params["w"] = [1.0, 2.0]
    with pytest.raises(ValueError, match="finite"):
        osc.params["w"] = float("nan")


def test_parameters_given_to_solve_apply_to_that_run_only(osc):
    sol = osc.solve("start", (0, np.pi), "dopri5", rtol=1e-12, atol=1e-12, params={"w": 1.0})
    np.testing.assert_allclose(sol.y[:, -1], [-1, 0], atol=1e-9)
    assert osc.params["w"] == 2.0


def test_a_model_error_keeps_file_line_and_column():
    bad = OSCILLATOR.replace("d/dt p = -w^2 * q;", "d/dt p = -w^2 * qq;")
    with pytest.raises(lasalle.ModelError) as info:
        lasalle.Model.from_source(bad, path="osc.lsl")
    e = info.value
    assert (e.file, e.line) == ("osc.lsl", 5)
    assert bad.splitlines()[e.line - 1][e.column - 1 :].startswith("qq")
    assert "qq" in e.diagnostic and "osc.lsl:5:" in e.diagnostic


def test_a_model_whose_integral_is_not_conserved_is_refused():
    bad = OSCILLATOR.replace("integral E = p^2/2 + w^2 * q^2/2", "integral E = p^2/2 + q^2/2")
    with pytest.raises(lasalle.ModelError) as info:
        lasalle.Model.from_source(bad, path="osc.lsl")
    assert info.value.line == 6


def test_unknown_models_and_backends_are_value_errors():
    with pytest.raises(ValueError, match="built-in models: .*kepler"):
        lasalle.Model("no_such_model")
    with pytest.raises(ValueError, match="backend"):
        lasalle.Model("kepler", backend="gpu")
    with pytest.raises(OSError):
        lasalle.Model("missing/file.lsl")


def test_models_pickle_by_source_and_parameters(osc):
    osc.params["w"] = 3.0
    back = pickle.loads(pickle.dumps(osc))
    assert back.source == osc.source and back.params["w"] == 3.0 and back.path == "osc.lsl"
    a = osc.solve("start", (0, 1), "rk4", dt=1e-3)
    b = back.solve("start", (0, 1), "rk4", dt=1e-3)
    assert np.array_equal(a.y, b.y)


def test_the_interpreter_gives_the_jits_numbers_to_rounding():
    jit = lasalle.Model("kepler")
    interp = lasalle.Model("kepler", backend="interpreter")
    a = jit.solve("paper", (0, 10), "feedback-rk4", dt=0.01)
    b = interp.solve("paper", (0, 10), "feedback-rk4", dt=0.01)
    np.testing.assert_allclose(a.y, b.y, rtol=0, atol=1e-12)
