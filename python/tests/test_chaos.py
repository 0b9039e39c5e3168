"""The variational equations and chaos indicators from Python: against closed forms, the
known behaviour of MEGNO and of Hamiltonian spectra, and bitwise against the command line."""

import csv
import json
import os
import pathlib
import subprocess
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

import lasalle

ROOT = pathlib.Path(__file__).resolve().parents[2]
CLI = pathlib.Path(os.environ.get("LASALLE_BIN", ROOT / "target" / "release" / "lasalle"))
needs_cli = pytest.mark.skipif(not CLI.is_file(), reason="the lasalle binary is not built (cargo build --release)")

# the chaotic sea and a quasi-periodic orbit of E = 1/8 (models/henon_heiles.lsl)
TOL = dict(rtol=1e-10, atol=1e-10)


@pytest.fixture(scope="module")
def hh():
    return lasalle.Model("henon_heiles")


def section_points(hh, q1s, p1s):
    """States on the section q₀ = 0 of E = 1/8, p₀ > 0 solved from the energy."""
    rows = []
    for q1, p1 in zip(q1s, p1s):
        p0 = np.sqrt(2 * (0.125 - (p1**2 + q1**2) / 2 + q1**3 / 3))
        state = dict(zip(hh.state_names, [0.0, q1, p0, p1]))
        rows.append([state[n] for n in hh.state_names])
    return np.array(rows)


@pytest.mark.parametrize("method, tol", [("dopri5", dict(rtol=1e-12, atol=1e-12)), ("taylor", dict(rtol=1e-14))])
def test_stm_of_the_harmonic_oscillator_is_its_closed_form(osc, method, tol):
    # q'' = -w² q: Φ(t) = [[cos wt, sin wt / w], [-w sin wt, cos wt]]
    w, t = 2.0, 3.7
    sol = osc.solve("start", (0, t), method, variational=True, **tol)
    exact = np.array([[np.cos(w * t), np.sin(w * t) / w], [-w * np.sin(w * t), np.cos(w * t)]])
    assert sol.stm.shape == (2, 2)
    np.testing.assert_allclose(sol.stm, exact, rtol=0, atol=1e-9)
    assert sol.lyapunov_spectrum is None and sol.megno is None
    assert sol.extended_runs["variational"]["steps"] > 0


def test_stm_follows_the_params_of_the_call(osc):
    sol = osc.solve("start", (0, 1.0), "dopri5", variational=True, params={"w": 3.0}, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(sol.stm[0, 0], np.cos(3.0), atol=1e-9)
    assert osc.params["w"] == 2.0


def test_megno_of_a_regular_orbit_tends_to_two(hh):
    sol = hh.solve("regular", (0, 5000), "dopri5", megno=True, **TOL)
    assert abs(sol.megno - 2) < 0.005
    assert abs(sol.mle) < 0.002
    assert sol.fli is None


def test_megno_of_a_chaotic_orbit_grows(hh):
    early = hh.solve("chaotic", (0, 500), "dopri5", megno=True, fli=True, **TOL)
    late = hh.solve("chaotic", (0, 2000), "dopri5", megno=True, fli=True, **TOL)
    # ⟨Y⟩ ≈ λt/2 with λ ≈ 0.05 in the chaotic sea
    assert 4 < early.megno < late.megno
    assert late.megno > 2 * early.megno
    assert late.fli > early.fli > 0


def test_lyapunov_spectrum_of_a_hamiltonian_orbit_sums_to_zero_and_is_sorted(hh):
    sol = hh.solve("chaotic", (0, 5000), "dopri5", lyapunov_spectrum=True, **TOL)
    s = sol.lyapunov_spectrum
    assert s.shape == (4,)
    assert np.all(np.diff(s) < 0)
    # the flow keeps volume: the exponents sum to 0
    assert abs(s.sum()) < 1e-8
    # (λ, 0, 0, −λ): the pairs of a symplectic flow, converging as 1/t
    assert s[0] > 0.02 and abs(s[0] + s[3]) < 0.02 * s[0]
    assert max(abs(s[1]), abs(s[2])) < 0.05 * s[0]
    assert sorted(sol.lyapunov_spectrum_qr_order, reverse=True) == list(s)
    assert sol.renormalisations == 5000


def test_indicators_are_bitwise_the_command_lines(hh, tmp_path):
    if not CLI.is_file():
        pytest.skip("the lasalle binary is not built (cargo build --release)")
    out = subprocess.run(
        [str(CLI), "run", "henon_heiles", "-m", "dopri5", "--t-end", "150", "--init", "chaotic",
         "--rtol", "1e-10", "--atol", "1e-10", "--renormalise-every", "0.5",
         "--variational", "--lyapunov-spectrum", "--megno", "--fli",
         "--format", "json", "--out", str(tmp_path)],
        capture_output=True, text=True, check=True,
    )
    summary = json.loads(out.stdout)
    # the first step as the command line's run took it (0: dopri5's own choice)
    sol = hh.solve("chaotic", (0, 150), "dopri5", dt=summary["dt"] or None, variational=True, lyapunov_spectrum=True,
                   renormalise_every=0.5, megno=True, fli=True, **TOL)
    assert sol.y[:, -1].tolist() == summary["final_state"]
    assert sol.stm.tolist() == summary["variational"]["phi"]
    assert sol.lyapunov_spectrum.tolist() == summary["lyapunov_spectrum"]
    assert sol.lyapunov_spectrum_qr_order.tolist() == summary["lyapunov_spectrum_qr_order"]
    assert sol.renormalisations == summary["renormalisations"]
    for key in ("megno", "megno_y", "fli", "mle"):
        assert getattr(sol, key) == summary[key], key
    for run in ("variational", "lyapunov_spectrum", "indicators"):
        assert sol.extended_runs[run]["steps"] == summary["extended_runs"][run]["steps"]


@needs_cli
@pytest.mark.parametrize("indicator, method, tol", [("megno", "taylor", ["--rtol", "1e-10"]), ("fli", "dopri5", ["--rtol", "1e-10", "--atol", "1e-10"]), ("megno", "rk4", ["--dt", "0.05"])])
def test_solve_many_indicators_are_bitwise_the_sweeps(hh, tmp_path, indicator, method, tol):
    q1 = np.array([-0.1, 0.2, 0.05, -0.3, 0.0])
    p1 = np.array([0.0, 0.1, -0.2, 0.05, 0.0])
    y0s = section_points(hh, q1, p1)
    names = hh.state_names
    ics = tmp_path / "ics.csv"
    with open(ics, "w") as f:
        f.write(",".join(names) + "\n")
        for row in y0s:
            f.write(",".join(repr(float(v)) for v in row) + "\n")
    table = tmp_path / "map.csv"
    subprocess.run(
        [str(CLI), "sweep", "henon_heiles", "--list", str(ics), "--indicator", indicator, "-m", method, *tol,
         "--t-end", "60", "--out", str(table), "--threads", "2"],
        capture_output=True, text=True, check=True,
    )
    with open(table) as f:
        cli = list(csv.DictReader(f))
    kwargs = dict(zip(tol[::2], tol[1::2]))
    kwargs = {k.lstrip("-"): float(v) for k, v in kwargs.items()}
    sols = hh.solve_many(y0s, (0, 60), method, threads=2, **{indicator: True}, **kwargs)
    assert sols.megno.shape == (5,) and sols.y.shape[:2] == (5, 4)
    assert sols.success.all()
    assert sols.megno.tolist() == [float(r["megno"]) for r in cli]
    assert sols.mle.tolist() == [float(r["mle"]) for r in cli]
    final = [[float(r[f"{n}(T)"]) for n in names] for r in cli]
    assert sols.y[:, :, -1].tolist() == final
    if indicator == "fli":
        assert sols.fli.tolist() == [float(r["fli"]) for r in cli]
    else:
        assert sols.fli is None


def test_solve_many_megno_is_batch_first_and_tells_chaos_from_order(hh):
    y0s = np.array([hh.points["chaotic"], hh.points["regular"]])
    sols = hh.solve_many(y0s, (0, 1000), "dopri5", megno=True, **TOL)
    assert sols.megno.shape == (2,) and sols.megno_y.shape == (2,) and sols.mle.shape == (2,)
    assert sols.megno[0] > 8 and abs(sols.megno[1] - 2) < 0.05
    # a lone run's indicators are the row's
    lone = hh.solve(y0s[0], (0, 1000), "dopri5", megno=True, **TOL)
    assert lone.megno == sols.megno[0] and lone.mle == sols.mle[0]


def test_solve_many_indicators_through_a_process_pool_are_the_threads_bits(hh):
    y0s = section_points(hh, np.linspace(-0.3, 0.3, 7), np.zeros(7))
    serial = hh.solve_many(y0s, (0, 50), "dopri5", fli=True, **TOL)
    with ProcessPoolExecutor(2) as ex:
        sharded = hh.solve_many(y0s, (0, 50), "dopri5", fli=True, executor=ex, shards=3, **TOL)
    for name in ("megno", "megno_y", "mle", "fli"):
        assert getattr(sharded, name).tolist() == getattr(serial, name).tolist(), name
    assert np.array_equal(sharded.y, serial.y, equal_nan=True)


def test_a_failed_row_has_nan_indicators(hh):
    # the second row leaves the bounded region E > 1/6 and escapes to infinity
    escaping = dict(zip(["q[0]", "q[1]", "p[0]", "p[1]"], [0.0, 0.9, 0.6, 0.0]))
    y0s = np.array([hh.points["regular"], [escaping[n] for n in hh.state_names]])
    sols = hh.solve_many(y0s, (0, 100), "dopri5", megno=True, max_steps=20000, **TOL)
    assert sols.success[0] and not sols.success[1]
    assert np.isfinite(sols.megno[0]) and np.isnan(sols.megno[1])


@pytest.mark.parametrize("keyword", ["variational", "lyapunov_spectrum", "megno", "fli"])
def test_a_method_that_does_not_integrate_the_extension_is_refused_by_keyword(hh, keyword):
    with pytest.raises(ValueError, match=f"{keyword}=True: `feedback-rk4` does not integrate"):
        hh.solve("chaotic", (0, 1), "feedback-rk4", dt=0.01, **{keyword: True})


def test_solve_many_refuses_a_method_that_does_not_integrate_the_extension(hh):
    with pytest.raises(ValueError, match="fli=True: `stormer-verlet-a` does not integrate"):
        hh.solve_many(np.array([hh.points["chaotic"]]), (0, 1), "stormer-verlet-a", dt=0.01, fli=True)


def test_indicators_refuse_a_backward_span_and_a_bad_interval(hh):
    with pytest.raises(ValueError, match="megno=True: .*forwards in time"):
        hh.solve("chaotic", (0, -1), "dopri5", megno=True)
    with pytest.raises(ValueError, match="megno=True: .*forwards in time"):
        hh.solve_many(np.array([hh.points["chaotic"]]), (1, 0), "dopri5", megno=True)
    with pytest.raises(ValueError, match="renormalise_every=0: "):
        hh.solve("chaotic", (0, 1), "dopri5", lyapunov_spectrum=True, renormalise_every=0.0)
    with pytest.raises(ValueError, match="renormalise_every= applies to lyapunov_spectrum=True"):
        hh.solve("chaotic", (0, 1), "dopri5", megno=True, renormalise_every=0.5)
    # Φ runs backwards as the flow does
    back = hh.solve("chaotic", (0, -1), "dopri5", variational=True, **TOL)
    assert abs(np.linalg.det(back.stm) - 1) < 1e-8


def test_an_extended_run_that_fails_raises_naming_its_keyword(hh):
    # the run itself takes 2439 steps, the extended runs more
    assert hh.solve("chaotic", (0, 100), "dopri5", max_steps=2600, **TOL).success
    with pytest.raises(lasalle.LasalleError, match="lyapunov_spectrum=True: .*step budget"):
        hh.solve("chaotic", (0, 100), "dopri5", lyapunov_spectrum=True, max_steps=2600, **TOL)
    with pytest.raises(lasalle.LasalleError, match="megno=True: the extended run stopped: step budget"):
        hh.solve("chaotic", (0, 100), "dopri5", megno=True, max_steps=2600, **TOL)
