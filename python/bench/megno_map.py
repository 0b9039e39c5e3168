"""A MEGNO map of Hénon–Heiles from Python (``solve_many(…, megno=True)``) against ``lasalle
sweep --indicator megno`` on the same initial conditions: CPU and wall time of each, the two
maps compared bit for bit, and the map drawn with matplotlib.

    python3 scripts/megno_map_bench.py --ics-only --every 10 --out /tmp/map
    python python/bench/megno_map.py /tmp/map/megno_ics_every10.csv --cli target/release/lasalle
"""

import argparse
import csv
import os
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

import lasalle


def children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("ics", help="the initial conditions, a CSV with the state's components as columns")
    ap.add_argument("--cli", default="target/release/lasalle")
    ap.add_argument("--method", default="taylor")
    ap.add_argument("--t-end", type=float, default=300.0)
    ap.add_argument("--tol", type=float, default=1e-10)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--figure", default=None, help="draw the map into this file")
    args = ap.parse_args()

    hh = lasalle.Model("henon_heiles")
    with open(args.ics) as f:
        rows = list(csv.DictReader(f))
    y0s = np.array([[float(r[n.strip()]) for n in hh.state_names] for r in rows])
    tol = ["--rtol", str(args.tol)] + ([] if args.method == "taylor" else ["--atol", str(args.tol)])
    kwargs = dict(rtol=args.tol) if args.method == "taylor" else dict(rtol=args.tol, atol=args.tol)

    cpu, wall = time.process_time(), time.perf_counter()
    maps = hh.solve_many(y0s, (0, args.t_end), args.method, megno=True, threads=args.threads, **kwargs)
    py_cpu, py_wall = time.process_time() - cpu, time.perf_counter() - wall

    with tempfile.TemporaryDirectory() as tmp:
        table = os.path.join(tmp, "map.csv")
        cpu, wall = children_cpu(), time.perf_counter()
        subprocess.run(
            [args.cli, "sweep", "henon_heiles", "--list", args.ics, "--indicator", "megno", "-m", args.method, *tol,
             "--t-end", str(args.t_end), "--out", table, "--threads", str(args.threads)],
            check=True, capture_output=True,
        )
        cli_cpu, cli_wall = children_cpu() - cpu, time.perf_counter() - wall
        with open(table) as f:
            cli = np.array([float(r["megno"]) if r["megno"] else np.nan for r in csv.DictReader(f)])

    same = np.array_equal(maps.megno, cli, equal_nan=True)
    b = len(y0s)
    print(f"{b} orbits, {args.method}, tol {args.tol:g}, t = {args.t_end:g}, {args.threads} thread(s)")
    print(f"solve_many(megno=True): CPU {py_cpu:.2f} s ({1e6 * py_cpu / b:.0f} µs per orbit), wall {py_wall:.2f} s")
    print(f"lasalle sweep --indicator megno: CPU {cli_cpu:.2f} s ({1e6 * cli_cpu / b:.0f} µs per orbit), "
          f"wall {cli_wall:.2f} s (the figure included)")
    print(f"the maps bitwise equal: {same}; chaotic (⟨Y⟩ > 4): {np.mean(maps.megno > 4):.3f} of the orbits")
    if args.figure:
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6, 5))
        q1, p1 = y0s[:, hh.state_names.index("q[1]")], y0s[:, hh.state_names.index("p[1]")]
        sc = ax.scatter(q1, p1, c=np.clip(maps.megno, 0, 8), s=6, cmap="viridis")
        fig.colorbar(sc, label="⟨Y⟩")
        ax.set_xlabel("q[1]")
        ax.set_ylabel("p[1]")
        fig.savefig(args.figure, dpi=100)
    sys.exit(0 if same else 1)


if __name__ == "__main__":
    main()
