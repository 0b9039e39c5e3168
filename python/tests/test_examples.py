"""The examples run, and say what they claim."""

import importlib.util
import pathlib

import numpy as np

EXAMPLES = pathlib.Path(__file__).resolve().parents[1] / "examples"


def load(name):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_kepler_drift_feedback_keeps_the_invariants_that_dop853_lets_drift(tmp_path):
    figure = tmp_path / "drift.png"
    rows = load("kepler_drift").main(periods=20, figure=str(figure))
    fb_L, fb_A, _, _ = rows["lasalle feedback-dopri5"]
    sp_L, sp_A, _, _ = rows["scipy DOP853"]
    assert fb_A < sp_A / 10 and fb_L < sp_L
    assert figure.stat().st_size > 10_000 and figure.read_bytes()[:4] == b"\x89PNG"


def test_the_sweep_agrees_with_keplers_equation():
    sols, error = load("sweep").main(orbits=100, t_end=20.0)
    assert sols.y.shape == (100, 6, 2)
    assert error.max() < 1e-9
    # the motion stays in the plane z = 0
    assert np.all(sols.y[:, 2, -1] == 0)


def test_a_new_users_model_sweep_and_dask_cluster_agree_bitwise_with_the_command_line():
    import os

    cli = pathlib.Path(os.environ.get("LASALLE_BIN", EXAMPLES.parents[1] / "target" / "release" / "lasalle"))
    out = load("new_user").main(cli=str(cli) if cli.is_file() else None, rows=200)
    # RK4 lets the Lotka–Volterra integral drift; its feedback form keeps it closer
    assert out["drift"]["feedback-rk4"] < out["drift"]["rk4"] / 2
    assert out.get("cli", "bitwise equal") == "bitwise equal"
