"""A new user's first run: a model file of one's own (Lotka–Volterra, `lotka_volterra.lsl`
next to this script), a feedback integrator, a sweep of 1000 initial conditions on all cores,
the same sweep on a Dask cluster of process workers, and the command line's `lasalle run` and
`lasalle sweep` on the same problem: every result bitwise equal to the others.

    python examples/new_user.py [path/to/lasalle]     # the binary: cargo build --release
"""

import json
import pathlib
import subprocess
import sys
import tempfile
import time

import numpy as np

import lasalle

HERE = pathlib.Path(__file__).resolve().parent
MODEL = HERE / "lotka_volterra.lsl"
T_END, DT, METHOD = 200.0, 0.05, "feedback-rk4"


def command_line(cli, y0s, single):
    """`lasalle run` of the model's start and `lasalle sweep` of the rows `y0s`: the final
    states, the run's largest drift."""
    with tempfile.TemporaryDirectory() as tmp:
        flags = ["-m", METHOD, "--dt", str(DT), "--t-end", str(T_END)]
        out = subprocess.run(
            [cli, "run", str(MODEL), *flags, "--format", "json", "--out", f"{tmp}/run"],
            capture_output=True, text=True, check=True,
        )
        summary = json.loads(out.stdout)
        rows = pathlib.Path(tmp) / "rows.csv"
        # shortest round-trip decimals: the command line reads the same bits
        rows.write_text("x,y\n" + "".join(f"{float(x)!r},{float(y)!r}\n" for x, y in y0s))
        table = pathlib.Path(tmp) / "sweep.csv"
        subprocess.run(
            [cli, "sweep", str(MODEL), *flags, "--list", str(rows), "--out", str(table)],
            capture_output=True, text=True, check=True,
        )
        lines = table.read_text().splitlines()
        header = lines[0].split(",")
        cols = [header.index("x(T)"), header.index("y(T)")]
        finals = np.array([[float(line.split(",")[c]) for c in cols] for line in lines[1:]])
    return np.array(summary["final_state"]), summary["invariant_errors"]["V"]["max"], finals


def main(cli=None, rows=1000, workers=2):
    out = {}
    start = time.perf_counter()
    m = lasalle.Model(MODEL)
    out["load_seconds"] = time.perf_counter() - start
    # one orbit: the feedback integrator keeps V = δx − γ ln x + βy − α ln y, RK4 lets it drift
    fb = m.solve("start", (0, T_END), METHOD, dt=DT)
    plain = m.solve("start", (0, T_END), "rk4", dt=DT)
    assert fb.success and plain.success
    out["drift"] = {METHOD: float(fb.max_drift[0]), "rk4": float(plain.max_drift[0])}

    # 1000 initial conditions on all cores
    y0s = np.column_stack([np.linspace(0.5, 8.0, rows), np.linspace(0.4, 3.0, rows)])
    cpu, wall = time.process_time(), time.perf_counter()
    many = m.solve_many(y0s, (0, T_END), METHOD, dt=DT)
    out["solve_many"] = (time.perf_counter() - wall, time.process_time() - cpu)
    assert many.success.all()
    for i in (0, rows // 2, rows - 1):
        lone = m.solve(y0s[i], (0, T_END), METHOD, dt=DT, every=2**64 - 1)
        assert np.array_equal(lone.y, many.y[i]) and np.array_equal(lone.max_drift, many.max_drift[i])

    # the same sweep on a Dask cluster of process workers
    from dask.distributed import Client, LocalCluster

    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with Client(cluster) as client:
            wall = time.perf_counter()
            dasked = m.solve_many(y0s, (0, T_END), METHOD, dt=DT, executor=client.get_executor(), shards=8)
            out["dask"] = time.perf_counter() - wall
    assert np.array_equal(dasked.y, many.y) and np.array_equal(dasked.max_drift, many.max_drift)

    # the command line's run and sweep
    if cli is not None:
        final, drift, finals = command_line(cli, y0s, fb)
        assert np.array_equal(final, fb.y[:, -1]) and drift == fb.max_drift[0]
        assert np.array_equal(finals, many.y[:, :, -1])
        out["cli"] = "bitwise equal"
    return out


if __name__ == "__main__":
    result = main(sys.argv[1] if len(sys.argv) > 1 else None)
    print(f"model loaded in {result['load_seconds'] * 1e3:.1f} ms")
    print(f"max drift of V over t = {T_END}: " + ", ".join(f"{k} {v:.2e}" for k, v in result["drift"].items()))
    wall, cpu = result["solve_many"]
    print(f"solve_many, 1000 rows on all cores: {wall:.3f} s wall, {cpu:.3f} s CPU")
    print(f"the same on a Dask LocalCluster (2 process workers): {result['dask']:.3f} s wall")
    print("Dask, solve_many and lone solves: bitwise equal" + (", and to the command line" if "cli" in result else ""))
