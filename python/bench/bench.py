"""lasalle from Python, side by side with heyoka.py and scipy: CPU time (and wall time).

    python python/bench/bench.py [--orbits 1024] [--t-end 20] [--scipy-orbits 64] [--wheel PATH]

Needs lasalle, numpy and scipy; heyoka (``pip install heyoka``) for its columns, skipped when
absent. Prints a Markdown table (the one in docs/python.md).

The orbits: 1024 Kepler orbits (μ = 1) from periapsis x = (1, 0, 0) with speeds
v ∈ [1.05, 1.35] (eccentricities 0.10 … 0.82), to t = 20; every result is checked against
Kepler's equation (the "max error" column: the largest position error over the orbits).
CPU time is the process's (all threads: ``time.process_time``), wall time the elapsed time.
"""

import argparse
import os
import subprocess
import sys
import time

import numpy as np

import lasalle


def orbits(n):
    v = np.linspace(1.05, 1.35, n)
    y0s = np.zeros((n, 6))
    y0s[:, 0] = 1.0
    y0s[:, 4] = v
    return y0s


def kepler_position(v, t):
    """Positions (n, 2) at time t of the orbits from periapsis (1, 0) with speeds v."""
    a = 1 / (2 - v**2)
    e = v**2 - 1
    mean = t / a**1.5
    E = np.array(mean, dtype=float)
    for _ in range(50):
        E = E - (E - e * np.sin(E) - mean) / (1 - e * np.cos(E))
    return np.stack([a * (np.cos(E) - e), a * np.sqrt(1 - e**2) * np.sin(E)], axis=1)


def timed(f, repeat=1):
    """(result, CPU seconds, wall seconds) of the fastest of `repeat` calls."""
    best = None
    for _ in range(repeat):
        c, w = time.process_time(), time.perf_counter()
        out = f()
        c, w = time.process_time() - c, time.perf_counter() - w
        if best is None or c < best[1]:
            best = (out, c, w)
    return best


def error(y_final, y0s, t_end):
    """The largest position error against Kepler's equation."""
    exact = kepler_position(y0s[:, 4], t_end)
    return float(np.max(np.linalg.norm(y_final[:, :2] - exact, axis=1)))


def heyoka_system():
    import heyoka as hy

    x, y, z, vx, vy, vz = hy.make_vars("x", "y", "z", "vx", "vy", "vz")
    r3 = (x**2 + y**2 + z**2) ** -1.5
    return [(x, vx), (y, vy), (z, vz), (vx, -x * r3), (vy, -y * r3), (vz, -z * r3)]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--orbits", type=int, default=1024)
    ap.add_argument("--t-end", type=float, default=20.0)
    ap.add_argument("--scipy-orbits", type=int, default=64, help="scipy's loop runs on this many and is scaled")
    ap.add_argument("--wheel", help="the wheel file, for its size")
    args = ap.parse_args()
    n, t_end = args.orbits, args.t_end
    y0s = orbits(n)
    rows = []  # (what, tool, cpu, wall, note)

    try:
        import heyoka as hy
    except ImportError:
        hy = None

    # -- model construction, cold: in a fresh process (heyoka caches compiled code in memory) --
    cold = (
        "import time, sys\n"
        "{setup}\n"
        "c, w = time.process_time(), time.perf_counter()\n"
        "{build}\n"
        "print(time.process_time() - c, time.perf_counter() - w)\n"
    )

    def construction(setup, build):
        best = None
        for _ in range(3):
            out = subprocess.run(
                [sys.executable, "-c", cold.format(setup=setup, build=build)], capture_output=True, text=True, check=True
            )
            c, w = (float(v) for v in out.stdout.split())
            best = (c, w) if best is None or c < best[0] else best
        return best

    c, w = construction("import lasalle", "lasalle.Model('kepler')")
    rows.append(("model construction (Kepler), cold", "lasalle `Model(\"kepler\")`: parse, derive, check, JIT", c, w, "fresh process, best of 3"))
    if hy is not None:
        setup = (
            "import heyoka as hy\n"
            "x, y, z, vx, vy, vz = hy.make_vars('x', 'y', 'z', 'vx', 'vy', 'vz')\n"
            "r3 = (x**2 + y**2 + z**2) ** -1.5\n"
            "s = [(x, vx), (y, vy), (z, vz), (vx, -x * r3), (vy, -y * r3), (vz, -z * r3)]"
        )
        c, w = construction(setup, "hy.taylor_adaptive(s, [1.0, 0, 0, 0, 1.2, 0], tol=1e-15)")
        rows.append(("model construction (Kepler), cold", "heyoka.py `taylor_adaptive`, tol 1e-15 (LLVM)", c, w, "fresh process, best of 3"))
        c, w = construction(setup + "\nimport numpy as np", "hy.taylor_adaptive_batch(s, np.ones((6, 4)), tol=1e-15)")
        rows.append(("model construction (Kepler), cold", "heyoka.py `taylor_adaptive_batch`, batch 4", c, w, "fresh process, best of 3"))

    # -- Python overhead of one solve call ------------------------------------------------
    m = lasalle.Model("kepler")
    y0 = y0s[0]
    calls = 2000
    sols = []

    def many_calls():
        for _ in range(calls):
            sols.append(m.solve(y0, (0, 0.01), "rk4", dt=0.01))

    _, c, w = timed(many_calls)
    inside = sum(s.cpu_seconds for s in sols) / len(sols)
    rows.append(
        (
            "one `solve` call (1 RK4 step)",
            "lasalle",
            c / calls,
            w / calls,
            f"of which {inside * 1e6:.1f} µs CPU in the run itself",
        )
    )
    from scipy.integrate import solve_ivp

    def kepler(t, y):
        x = y[:3]
        return np.concatenate([y[3:], -x / np.linalg.norm(x) ** 3])

    _, c, w = timed(lambda: [solve_ivp(kepler, (0, 0.01), y0, method="RK45", first_step=0.01, max_step=0.01) for _ in range(200)])
    rows.append(("one `solve` call (1 RK4 step)", "scipy `solve_ivp` (1 RK45 step)", c / 200, w / 200, ""))

    fresh = lasalle.Model("kepler")
    sol, c, w = timed(lambda: fresh.solve(y0, (0, t_end), "taylor", rtol=1e-15))
    rows.append(
        (
            f"one Taylor run to t = {t_end:g}, tol 1e-15",
            "lasalle `solve`, the model's first (builds its Taylor kernels)",
            c,
            w,
            f"{sol.steps} steps taking {sol.cpu_seconds * 1e3:.2f} ms CPU",
        )
    )
    sol, c, w = timed(lambda: fresh.solve(y0, (0, t_end), "taylor", rtol=1e-15), repeat=5)
    rows.append(
        (
            f"one Taylor run to t = {t_end:g}, tol 1e-15",
            "lasalle `solve`, later runs (the kernels reused)",
            c,
            w,
            f"{sol.steps} steps taking {sol.cpu_seconds * 1e3:.2f} ms CPU",
        )
    )

    # -- ensembles ---------------------------------------------------------------------------
    dt = 1e-3
    res, c, w = timed(lambda: m.solve_many(y0s, (0, t_end), "rk4", dt=dt))
    assert res.success.all()
    rows.append((f"{n} orbits, RK4 dt = {dt:g}", "lasalle `solve_many` (threads, 8 lanes)", c, w, f"max error {error(res.y[:, :, -1], y0s, t_end):.1e}"))
    res1, c, w = timed(lambda: m.solve_many(y0s, (0, t_end), "rk4", dt=dt, lanes=1))
    assert np.array_equal(res1.y, res.y)
    rows.append((f"{n} orbits, RK4 dt = {dt:g}", "lasalle `solve_many` (threads, no lanes)", c, w, "bitwise the lanes' result"))

    tol = 1e-15
    res, c, w = timed(lambda: m.solve_many(y0s, (0, t_end), "taylor", rtol=tol))
    assert res.success.all()
    rows.append((f"{n} orbits, Taylor tol {tol:g}", "lasalle `solve_many` (threads)", c, w, f"max error {error(res.y[:, :, -1], y0s, t_end):.1e}"))
    if hy is not None:
        sys_ = heyoka_system()
        ta = hy.taylor_adaptive(sys_, y0s[0].copy(), tol=tol)

        def gen(ta_copy, i):
            ta_copy.time = 0.0
            ta_copy.state[:] = y0s[i]
            return ta_copy

        def ensemble():
            out = hy.ensemble_propagate_until(ta, t_end, n, gen)
            return np.array([r[0].state for r in out])

        yf, c, w = timed(ensemble)
        rows.append((f"{n} orbits, Taylor tol {tol:g}", "heyoka.py `ensemble_propagate_until` (threads)", c, w, f"max error {error(yf, y0s, t_end):.1e}"))
        batch = 4
        tb = hy.taylor_adaptive_batch(sys_, np.ascontiguousarray(y0s[:batch].T), tol=tol)

        def batches():
            out = np.empty((n, 6))
            for lo in range(0, n, batch):
                tb.set_time(0.0)
                tb.state[:] = y0s[lo : lo + batch].T
                tb.propagate_until(t_end)
                out[lo : lo + batch] = tb.state.T
            return out

        yf, c, w = timed(batches)
        rows.append((f"{n} orbits, Taylor tol {tol:g}", "heyoka.py `taylor_adaptive_batch` (batch 4, one thread)", c, w, f"max error {error(yf, y0s, t_end):.1e}"))

    k = min(args.scipy_orbits, n)

    def scipy_loop():
        return np.array(
            [solve_ivp(kepler, (0, t_end), y0s[i], method="DOP853", rtol=1e-13, atol=1e-13).y[:, -1] for i in range(k)]
        )

    yf, c, w = timed(scipy_loop)
    rows.append(
        (
            f"{n} orbits, Taylor tol {tol:g}",
            "scipy `solve_ivp` DOP853 loop, rtol = atol = 1e-13",
            c * n / k,
            w * n / k,
            f"{k} orbits timed, ×{n / k:g}; max error {error(yf, y0s[:k], t_end):.1e}",
        )
    )

    # -- the package itself ------------------------------------------------------------------
    # `import lasalle` in a fresh process, numpy imported first (its own import is not ours)
    probe = (
        "import time; import numpy; c, w = time.process_time(), time.perf_counter(); import lasalle; "
        "print(time.process_time() - c, time.perf_counter() - w)"
    )
    imports = []
    for _ in range(5):
        out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
        imports.append(tuple(float(v) for v in out.stdout.split()))
    imports.sort()
    print("| what | tool | CPU | wall | note |")
    print("|---|---|---:|---:|---|")
    for what, tool, c, w, note in rows:
        print(f"| {what} | {tool} | {fmt(c)} | {fmt(w)} | {note} |")
    print()
    print(
        f"`import lasalle` (numpy already imported): {imports[0][0] * 1e3:.1f} ms CPU, "
        f"{imports[0][1] * 1e3:.1f} ms wall (best of 5 fresh processes)"
    )
    if args.wheel:
        print(f"wheel: {os.path.basename(args.wheel)}, {os.path.getsize(args.wheel) / 1e6:.1f} MB")
    print(f"machine: {os.cpu_count()} cores; python {sys.version.split()[0]}" + (f"; heyoka {hy.__version__}" if hy else ""))


def fmt(seconds):
    if seconds < 1e-3:
        return f"{seconds * 1e6:.1f} µs"
    if seconds < 1:
        return f"{seconds * 1e3:.1f} ms"
    return f"{seconds:.2f} s"


if __name__ == "__main__":
    main()
