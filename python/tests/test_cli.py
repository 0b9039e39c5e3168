"""The package and the command line give the same bits (the same run engine)."""

import json
import os
import pathlib
import subprocess

import numpy as np
import pytest

import lasalle

ROOT = pathlib.Path(__file__).resolve().parents[2]
CLI = pathlib.Path(os.environ.get("LASALLE_BIN", ROOT / "target" / "release" / "lasalle"))


@pytest.mark.skipif(not CLI.is_file(), reason="the lasalle binary is not built (cargo build --release)")
@pytest.mark.parametrize(
    "method, flags, kwargs",
    [
        # the command line's run takes the preset `paper`, whose gains are the paper's
        ("feedback-rk4", ["--dt", "0.005"], dict(dt=0.005, gains=[4.0, 2.0])),
        ("feedback-dopri5", ["--rtol", "1e-10", "--atol", "1e-10"], dict(rtol=1e-10, atol=1e-10)),
        ("taylor", ["--rtol", "1e-14"], dict(rtol=1e-14)),
    ],
)
def test_solve_and_solve_many_give_the_command_lines_bits(kepler, tmp_path, method, flags, kwargs):
    out = subprocess.run(
        [str(CLI), "run", "kepler", "-m", method, "--t-end", "20", "--format", "json", "--out", str(tmp_path), *flags],
        capture_output=True,
        text=True,
        check=True,
    )
    summary = json.loads(out.stdout)
    sol = kepler.solve("paper", (0, 20), method, **kwargs)
    assert sol.y[:, -1].tolist() == summary["final_state"]
    assert sol.steps == summary["steps"] and sol.nfev == summary["evaluations"]
    for name, b in zip(kepler.integrals, range(2)):
        assert sol.max_drift[b] == summary["invariant_errors"][name]["max"]
    many = kepler.solve_many(np.tile(kepler.points["paper"], (3, 1)), (0, 20), method, **kwargs)
    assert many.y[:, :, -1].tolist() == [summary["final_state"]] * 3
