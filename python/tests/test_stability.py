"""lasalle.stability: the command's JSON as dicts, checked against closed forms and the CLI."""

import json
import os
import pathlib
import subprocess

import numpy as np
import pytest

import lasalle

ROOT = pathlib.Path(__file__).resolve().parents[2]
CLI = pathlib.Path(os.environ.get("LASALLE_BIN", ROOT / "target" / "release" / "lasalle"))
MU = 0.01215058560962404  # Earth–Moon


def plain(value):
    """Arrays back to lists, timings dropped: the JSON the command prints."""
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items() if k != "seconds"}
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, list):
        return [plain(v) for v in value]
    return value


def test_lie_poisson_equilibria_against_the_closed_form():
    # H = P₁²/(2c) + P₃ on |P| = ρ: ∇H + λP = 0 gives (±√(ρ² − c²), 0, c) with λ = −1/c, and
    # (0, 0, ±ρ) with λ = ∓1/ρ; the linearisation at (0, 0, ±ρ) has μ² = ±ρ/c − 1
    c, rho = 2.0, np.sqrt(17.0)
    r = lasalle.stability("so3_type_i")
    assert r["model"] == "So3TypeI" and r["params"]["c1"].tolist() == [c] and r["point"] is None
    level = r["level"]
    assert level["rho"] == pytest.approx(rho, rel=1e-15)
    eq = {tuple(np.round(e["p"], 9)): e for e in level["equilibria"]}
    p0 = np.sqrt(rho**2 - c**2)
    assert set(eq) == {(round(p0, 9), 0.0, c), (round(-p0, 9), 0.0, c), (0.0, 0.0, round(rho, 9)), (0.0, 0.0, round(-rho, 9))}
    for e in level["equilibria"]:
        p = e["p"]
        assert e["energy"] == pytest.approx(p[0] ** 2 / (2 * c) + p[2], abs=1e-12)
        if abs(p[0]) > 1:
            assert e["lambda"] == pytest.approx(-1 / c, abs=1e-12)
            assert e["verdict"]["verdict"] == "stable"
    top, bottom = eq[(0.0, 0.0, round(rho, 9))], eq[(0.0, 0.0, round(-rho, 9))]
    assert top["spectrum"] == {"kind": "real", "value": pytest.approx(np.sqrt(rho / c - 1), rel=1e-12)}
    assert top["verdict"]["verdict"] == "linearly_unstable"
    assert bottom["spectrum"] == {"kind": "imaginary", "value": pytest.approx(np.sqrt(rho / c + 1), rel=1e-12)}
    assert bottom["verdict"]["verdict"] == "stable"


def test_a_point_and_parameters():
    # at P = (0, 0, 1) with c = 4: μ² = 1/4 − 1 < 0, stable (a minimum of H + λC)
    r = lasalle.stability("so3_type_i", at=[0, 0, 1], params={"c1": 4.0}, levels=11)
    assert r["level"] is None and r["params"]["c1"].tolist() == [4.0]
    assert r["point"]["spectrum"]["value"] == pytest.approx(np.sqrt(1 - 1 / 4), rel=1e-12)
    assert len(r["sweep"]["rho"]) == 11


def test_domain_of_attraction_against_the_linearisation():
    # Duffing ẍ + ε₁ẋ + x − ε₂x³ = 0: A = [[0, 1], [−1, −ε₁]] at the origin, saddles at
    # x₁ = ±1/√ε₂ with eigenvalues 1 and −2 (λ² + ε₁λ − 2 = 0)
    r = lasalle.stability("duffing")
    a = r["analysis"]
    np.testing.assert_array_equal(a["jacobian"], [[0, 1], [-1, -1]])
    np.testing.assert_allclose(sorted(a["eigenvalues"][:, 1]), [-np.sqrt(3) / 2, np.sqrt(3) / 2], rtol=1e-15)
    # the Lyapunov-equation P solves AᵀP + PA = −Q
    A, P, Q = a["jacobian"], a["lyapunov_equation"]["p"], a["lyapunov_equation"]["q"]
    np.testing.assert_allclose(A.T @ P + P @ A, -Q, atol=1e-15)
    saddles = sorted(r["saddles"], key=lambda s: s["x"][0])
    np.testing.assert_allclose([s["x"] for s in saddles], [[-5, 0], [5, 0]], atol=1e-12)
    np.testing.assert_allclose(sorted(saddles[0]["eigenvalues"]), [-2, 1], atol=1e-12)
    assert r["lyapunov_let"]["name"] == "energy"
    # the energy estimate: E < ε₁ … the saddle's energy 1/(4ε₂) = 6.25
    assert r["lyapunov_let"]["estimate"]["level"] == pytest.approx(6.25, rel=1e-6)


def test_canonical_verdict_against_the_closed_forms():
    r = lasalle.stability("cr3bp", params={"mu": MU})
    s = np.sqrt(1 - 27 * MU * (1 - MU))
    np.testing.assert_allclose(r["omega"], np.sqrt([(1 + s) / 2, (1 - s) / 2]), rtol=1e-13)
    w = 27 * MU * (1 - MU) / 4
    d4 = (36 - 541 * w + 644 * w**2) / (8 * (1 - 4 * w) * (4 - 25 * w))
    assert r["verdict"]["kind"] == "stable-arnold-moser"
    assert r["verdict"]["d4"] == pytest.approx(d4, rel=1e-10)


@pytest.mark.skipif(not CLI.is_file(), reason="the lasalle binary is not built (cargo build --release)")
@pytest.mark.parametrize(
    "model, flags, kwargs",
    [
        ("so3_type_i", [], {}),
        ("so3_type_iia", ["--at", "0,0,1", "--levels", "21"], dict(at=[0, 0, 1], levels=21)),
        ("duffing", [], {}),
        ("duffing", ["--param", "eps2=0.05", "--radius", "4"], dict(params={"eps2": 0.05}, radius=4.0)),
        ("cr3bp", ["--time-bound", "1e-4,1e-2", "--order", "6"], dict(time_bound=[(1e-4, 1e-2)], order=6)),
    ],
)
def test_the_command_lines_json(model, flags, kwargs):
    out = subprocess.run(
        [str(CLI), "stability", model, "--format", "json", *flags], capture_output=True, text=True, check=True
    )
    assert plain(lasalle.stability(model, **kwargs)) == plain(json.loads(out.stdout))


@pytest.mark.parametrize(
    "model, kwargs, match",
    [
        ("duffing", dict(casimir=2.0), "casimir= does not apply"),
        ("cr3bp", dict(at=[1, 2]), "at= does not apply"),
        ("so3_type_i", dict(time_bound=[(1e-3, 2e-3)]), "does not apply"),
        ("so3_type_i", dict(at=[1, 2]), "3 numbers"),
        ("duffing", dict(at=[5, 0]), "not asymptotically stable"),
        ("cr3bp", dict(time_bound=[(2e-3, 1e-3)]), "time_bound=0.002,0.001"),
        ("cr3bp", dict(validate=True), "needs time_bound"),
        ("cr3bp", dict(certified=True), "needs time_bound"),
        ("duffing", dict(certified=True), "does not apply"),
        ("cr3bp", dict(metric="taxicab"), "metric"),
        ("so3_type_i", dict(range=(2, 1)), "0 < a < b"),
    ],
)
def test_bad_settings_are_value_errors(model, kwargs, match):
    with pytest.raises(ValueError, match=match):
        lasalle.stability(model, **kwargs)


def test_no_stable_named_point_asks_for_at():
    src = "model Flip { state x: scalar, y: scalar; d/dt x = x; d/dt y = -y; point o { x = 0; y = 0; } }"
    with pytest.raises(ValueError, match=r"give one with at=\[x1, x2\]"):
        lasalle.stability(lasalle.Model.from_source(src))
