#!/usr/bin/env python3
"""MEGNO map of the Hénon–Heiles system: lasalle against heyoka.py, the same equations.

The initial conditions: the section q0 = 0 of the energy level E = 1/8 (Hénon & Heiles 1964),
a grid in (q1, p1), p0 > 0 solved from the energy; the grid is refined until it holds at
least `--points` states. Both programs integrate the same extended system to the same time at
the same tolerance, the state x, a unit tangent vector u, ℓ = ln‖w‖, the clock τ and the MEGNO
integrals a, b (the equations of `lasalle_model::variational`, their Jacobian derived
symbolically by each program: lasalle by its front end, heyoka by `hy.diff`):

    u' = Au − λu,  ℓ' = λ,  τ' = 1,  a' = τλ,  b' = 2aτ/(τ² + 1e-20),  λ = u·Au/u·u,

and ⟨Y⟩ = b/τ at the end. lasalle runs `lasalle sweep --indicator megno` (its Taylor method,
and DOPRI5), heyoka `taylor_adaptive_batch` through `ensemble_propagate_until_batch`, both on
all cores. CPU time is the process's (all threads); heyoka's includes compiling the
integrator once, shown apart.

    heyoka-venv/bin/python scripts/megno_map_bench.py --out docs/chaos

writes the initial conditions (`megno_ics.csv`, the `--list` of `lasalle sweep`), the table
(`megno_bench.md`), both maps (`megno_map.csv` and lasalle's figure `megno_map.png`) and prints
the table.

    python3 scripts/megno_map_bench.py --ics-only --out docs/chaos

writes `megno_ics.csv` alone (the standard library suffices: no numpy, no heyoka).
"""

import argparse
import math
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

try:
    import numpy as np
except ImportError:  # --ics-only needs the standard library alone
    np = None

ROOT = Path(__file__).resolve().parent.parent
E = 1.0 / 8.0


def grid(points):
    """The admissible (q1, p1, p0) of an n×n grid over the section's bounding box, n the
    smallest giving at least `points` states."""
    q_lo, q_hi, p_lo, p_hi = -0.42, 0.68, -0.5, 0.5
    n = int(math.sqrt(points))
    while True:
        out = []
        for q1 in linspace(q_lo, q_hi, n):
            for p1 in linspace(p_lo, p_hi, n):
                p0sq = 2.0 * E - p1 * p1 - q1 * q1 + 2.0 * q1 ** 3 / 3.0
                if p0sq > 0.0:
                    out.append((float(q1), float(p1), math.sqrt(p0sq)))
        if len(out) >= points:
            return n, out
        n += 1


def linspace(lo, hi, n):
    """numpy's linspace, value for value: lo + k·step, the last one hi itself."""
    step = (hi - lo) / (n - 1)
    return [lo + k * step for k in range(n - 1)] + [hi]


def write_listing(ics, path):
    """The `--list` CSV of `lasalle sweep`: a header of state components, a row per orbit."""
    with open(path, "w") as f:
        f.write("q[1],p[1],q[0],p[0]\n")
        for q1, p1, p0 in ics:
            f.write(f"{q1!r},{p1!r},0,{p0!r}\n")


def children_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run_lasalle(ics, t_end, tol, method, out_dir, threads, every, lanes=8):
    suffix = ("" if every == 1 else f"_every{every}") + ("" if lanes == 8 else f"_lanes{lanes}")
    listing = out_dir / f"megno_ics{suffix}.csv"
    write_listing(ics, listing)
    table = out_dir / (f"megno_map{suffix}.csv" if method == "taylor"
                       else f"megno_map_{method}{suffix}.csv")
    exe = os.environ.get("LASALLE", str(ROOT / "target/release/lasalle"))
    cmd = [exe, "sweep", str(ROOT / "models/henon_heiles.lsl"), "--list", str(listing),
           "--indicator", "megno", "-m", method, "--rtol", repr(tol), "--atol", repr(tol),
           "--t-end", repr(t_end), "--out", str(table), "--threads", str(threads),
           "--lanes", str(lanes)]
    cpu0, wall0 = children_cpu(), time.perf_counter()
    subprocess.run(cmd, check=True)
    cpu, wall = children_cpu() - cpu0, time.perf_counter() - wall0
    header, *rows = table.read_text().splitlines()
    col = header.split(",").index("megno")
    megno = np.array([float(r.split(",")[col]) if r.split(",")[col] else np.nan for r in rows])
    return cpu, wall, megno, " ".join(cmd[1:]).replace(str(ROOT) + "/", "")


def run_heyoka(ics, t_end, tol, threads, batch=None):
    """heyoka's ensemble of the map: `taylor_adaptive_batch` of the host's SIMD width, or of
    `batch` orbits (1: the scalar `taylor_adaptive`)."""
    import heyoka as hy

    q0, q1, p0, p1 = hy.make_vars("q0", "q1", "p0", "p1")
    x = [q0, q1, p0, p1]
    u = list(hy.make_vars("u0", "u1", "u2", "u3"))
    ell, tau, a, b = hy.make_vars("ell", "tau", "a", "b")
    H = (p0**2 + p1**2 + q0**2 + q1**2) / 2 + q0**2 * q1 - q1**3 / 3
    X = [hy.diff(H, p0), hy.diff(H, p1), -hy.diff(H, q0), -hy.diff(H, q1)]
    A = [[hy.diff(Xi, xj) for xj in x] for Xi in X]
    Au = [hy.sum([A[i][j] * u[j] for j in range(4)]) for i in range(4)]
    lam = hy.sum([u[i] * Au[i] for i in range(4)]) / hy.sum([ui * ui for ui in u])
    sys_ = [(x[i], X[i]) for i in range(4)]
    sys_ += [(u[i], Au[i] - lam * u[i]) for i in range(4)]
    sys_ += [(ell, lam), (tau, hy.expression(1.0)), (a, tau * lam),
             (b, 2.0 * a * tau / (tau * tau + 1e-20))]
    batch = batch or hy.recommended_simd_size()
    count = len(ics)
    ics = list(ics)
    while len(ics) % batch:
        ics.append(ics[-1])
    u0 = 0.5  # (1, 1, 1, 1)/2

    def state(chunk):
        s = np.zeros((12, batch))
        for k, (q1v, p1v, p0v) in enumerate(chunk):
            s[:, k] = [0.0, q1v, p0v, p1v, u0, u0, u0, u0, 0, 0, 0, 0]
        return s

    cpu0, wall0 = time.process_time(), time.perf_counter()
    chunks = [ics[i:i + batch] for i in range(0, len(ics), batch)]
    if batch == 1:
        ta = hy.taylor_adaptive(sys_, state(ics[:1])[:, 0], tol=tol)
        compile_cpu = time.process_time() - cpu0

        def gen(ta_copy, i):
            ta_copy.time = 0.0
            ta_copy.state[:] = state(chunks[i])[:, 0]
            return ta_copy

        res = hy.ensemble_propagate_until(ta, t_end, len(chunks), gen, max_workers=threads)
    else:
        ta = hy.taylor_adaptive_batch(sys_, state(ics[:batch]), tol=tol)
        compile_cpu = time.process_time() - cpu0

        def gen(ta_copy, i):
            ta_copy.set_time(0.0)
            ta_copy.state[:] = state(chunks[i])
            return ta_copy

        res = hy.ensemble_propagate_until_batch(ta, t_end, len(chunks), gen, max_workers=threads)
    cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    megno = []
    for r in res:
        s = r[0].state
        megno.extend(np.atleast_1d(s[11] / s[9]))
    return cpu, wall, compile_cpu, np.array(megno[:count]), batch


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--points", type=int, default=10_000)
    ap.add_argument("--t-end", type=float, default=200.0)
    ap.add_argument("--tol", type=float, default=1e-10)
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--out", type=Path, default=ROOT / "docs/chaos")
    ap.add_argument("--no-dopri5", action="store_true")
    ap.add_argument("--every", type=int, default=1,
                    help="time every k-th initial condition of the grid only")
    ap.add_argument("--ics-only", action="store_true",
                    help="write the initial conditions (megno_ics.csv) and stop")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    n, ics = grid(args.points)
    ics = ics[:: args.every]
    if args.ics_only:
        suffix = "" if args.every == 1 else f"_every{args.every}"
        write_listing(ics, args.out / f"megno_ics{suffix}.csv")
        print(f"{len(ics)} initial conditions -> {args.out}/megno_ics{suffix}.csv", file=sys.stderr)
        return
    print(f"{len(ics)} initial conditions ({n}x{n} grid on the E = 1/8 section), "
          f"t_end = {args.t_end}, tol = {args.tol}, {args.threads} threads", file=sys.stderr)
    rows = []
    las_cpu, las_wall, las_megno, cmd = run_lasalle(ics, args.t_end, args.tol, "taylor",
                                                    args.out, args.threads, args.every)
    rows.append(("lasalle sweep, taylor (JIT), lanes", las_cpu, las_wall, "–"))
    one_cpu, one_wall, one_megno, _ = run_lasalle(ics, args.t_end, args.tol, "taylor",
                                                  args.out, args.threads, args.every, lanes=1)
    assert np.array_equal(one_megno, las_megno, equal_nan=True), "lanes change the map"
    rows.append(("lasalle sweep, taylor (JIT), each orbit alone (`--lanes 1`)", one_cpu,
                 one_wall, "–"))
    if not args.no_dopri5:
        d_cpu, d_wall, d_megno, _ = run_lasalle(ics, args.t_end, args.tol, "dopri5",
                                                args.out, args.threads, args.every)
        rows.append(("lasalle sweep, dopri5 (JIT)", d_cpu, d_wall, "–"))
    hy_cpu, hy_wall, hy_compile, hy_megno, batch = run_heyoka(ics, args.t_end, args.tol,
                                                              args.threads)
    rows.append((f"heyoka.py {__import__('heyoka').__version__}, taylor_adaptive_batch "
                 f"(batch {batch}), ensemble", hy_cpu, hy_wall, f"{hy_compile:.2f}"))
    s_cpu, s_wall, s_compile, _, _ = run_heyoka(ics, args.t_end, args.tol, args.threads, batch=1)
    rows.append((f"heyoka.py {__import__('heyoka').__version__}, taylor_adaptive (scalar), "
                 f"ensemble", s_cpu, s_wall, f"{s_compile:.2f}"))
    chaotic_l, chaotic_h = las_megno > 4.0, hy_megno > 4.0
    agree = np.mean(chaotic_l == chaotic_h)
    both_regular = ~chaotic_l & ~chaotic_h
    diff = np.nanmax(np.abs(las_megno[both_regular] - hy_megno[both_regular]))
    lines = [
        f"MEGNO map of Hénon–Heiles, E = 1/8, section q0 = 0: {len(ics)} initial conditions "
        f"(every {args.every}. point of the admissible ones of a {n}×{n} grid in (q1, p1)), "
        f"t_end = {args.t_end}, tolerance {args.tol}, "
        f"{args.threads} threads.",
        "",
        "| integrator | CPU s | wall s | of which compiling (CPU s) | CPU µs per orbit |",
        "| --- | --- | --- | --- | --- |",
    ]
    for name, cpu, wall, comp in rows:
        lines.append(f"| {name} | {cpu:.1f} | {wall:.1f} | {comp} | {1e6 * cpu / len(ics):.0f} |")
    lines += [
        "",
        f"Chaotic (⟨Y⟩ > 4) in lasalle's map: {np.mean(chaotic_l):.3f} of the orbits; "
        f"lasalle and heyoka classify {agree:.4f} of the orbits alike; where both find "
        f"⟨Y⟩ ≤ 4 their values differ by at most {diff:.1e}.",
        "",
        f"lasalle's command: `lasalle {cmd}`",
    ]
    text = "\n".join(lines) + "\n"
    (args.out / f"megno_bench{'' if args.every == 1 else f'_every{args.every}'}.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
