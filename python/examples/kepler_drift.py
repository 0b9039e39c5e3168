"""Kepler's invariants along 100 orbits: lasalle's feedback Dormand–Prince next to scipy's
DOP853 at the same tolerance.

The paper's orbit (e = 0.8, period 70.2481): scipy's DOP853 lets the angular momentum L and
the Laplace–Runge–Lenz vector A drift with time; lasalle's ``feedback-dopri5`` integrates the
feedback field X − ∇V, which pulls the state back onto the level set of both. The drifts of
scipy's solution are computed here in numpy from the same formulas the model file declares.

    python examples/kepler_drift.py [periods] [figure.png]
"""

import sys
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

import lasalle  # noqa: E402

PERIOD = 2 * np.pi * 5**1.5  # a = 5 for the paper's point


def invariants(y):
    """L = x × v and A = v × L − x/|x| for states in the columns of y (6, n)."""
    x, v = y[:3], y[3:]
    L = np.cross(x, v, axis=0)
    A = np.cross(v, L, axis=0) - x / np.linalg.norm(x, axis=0)
    return L, A


def drifts(y):
    L, A = invariants(y)
    return (
        np.linalg.norm(L - L[:, :1], axis=0),
        np.linalg.norm(A - A[:, :1], axis=0),
    )


def main(periods=100, figure="kepler_drift.png", tol=1e-10):
    m = lasalle.Model("kepler")
    y0 = m.points["paper"]
    t_end = periods * PERIOD

    start = time.process_time()
    fb = m.solve(y0, (0, t_end), "feedback-dopri5", rtol=tol, atol=tol)
    fb_cpu = time.process_time() - start
    fb.raise_for_status()

    def kepler(t, y):
        x = y[:3]
        return np.concatenate([y[3:], -x / np.linalg.norm(x) ** 3])

    start = time.process_time()
    ref = solve_ivp(kepler, (0, t_end), y0, method="DOP853", rtol=tol, atol=tol)
    sp_cpu = time.process_time() - start
    sp_L, sp_A = drifts(ref.y)

    rows = {
        "lasalle feedback-dopri5": (fb.max_drift[0], fb.max_drift[1], fb.nfev, fb_cpu),
        "scipy DOP853": (sp_L.max(), sp_A.max(), ref.nfev, sp_cpu),
    }
    print(f"Kepler, e = 0.8, {periods} periods, rtol = atol = {tol:g}")
    print(f"{'':26} {'max |ΔL|':>10} {'max |ΔA|':>10} {'nfev':>9} {'CPU s':>7}")
    for name, (dl, da, nfev, cpu) in rows.items():
        print(f"{name:26} {dl:10.2e} {da:10.2e} {nfev:9d} {cpu:7.3f}")

    fig, ax = plt.subplots(figsize=(7, 4))
    for label, t, d, style in [
        ("|ΔA| scipy DOP853", ref.t, sp_A, "C0-"),
        ("|ΔL| scipy DOP853", ref.t, sp_L, "C0:"),
        ("|ΔA| lasalle feedback-dopri5", fb.t, fb.invariants[1], "C3-"),
        ("|ΔL| lasalle feedback-dopri5", fb.t, fb.invariants[0], "C3:"),
    ]:
        ax.semilogy(t / PERIOD, np.maximum(d, 1e-17), style, lw=0.8, label=label)
    ax.set_xlabel("periods")
    ax.set_ylabel("invariant drift")
    ax.set_title(f"Kepler e = 0.8, rtol = atol = {tol:g}")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(figure, dpi=120)
    plt.close(fig)
    return rows


if __name__ == "__main__":
    periods = int(sys.argv[1]) if len(sys.argv) > 1 else 100
    main(periods, sys.argv[2] if len(sys.argv) > 2 else "kepler_drift.png")
