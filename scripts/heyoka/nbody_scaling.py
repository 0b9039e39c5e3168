#!/usr/bin/env python3
"""The N-body family against heyoka's compact mode, N by N: one evaluation of the field and the
Taylor method's step.

    scripts/heyoka/nbody_scaling.py LASALLE_BIN [--sizes 3,6,12,24,48,96] [--t-end 1] [--tol 1e-15]
        [--families loops|auto|unrolled]

Run it with a Python that has heyoka (scripts/heyoka/run.sh makes one under
target/heyoka-venv); `scripts/performance.sh nbody-heyoka` does both and writes the table into
docs/performance.md. Prints a markdown table on stdout, progress on stderr.

lasalle: `models/nbody.lsl` with its `param n` line set to N, integrated from its point `ring`
by `lasalle run -m taylor --rtol TOL --families FAMILIES` (JIT; FAMILIES `loops` by default: the
field and its Taylor program in loop form, one loop per sum over the pairs; the run's own CPU
time from summary.json, the
process's CPU time, which adds loading, from the OS), and its field timed by
`lasalle bench-eval --field model --families FAMILIES` (one state per call, and 4 and 8 states
per call).

heyoka: `heyoka.model.nbody` with the same masses (G = 1) and the same initial state in
velocities, `taylor_adaptive(..., tol=TOL, compact_mode=True)` (its construction timed, then
`propagate_until(T)`; the first construction in the process, as heyoka caches compiled code),
and `cfunc(..., compact_mode=True)` called on 1024 states at once.
All times are CPU time, the fastest of `--repeat` runs.
"""
import argparse
import json
import math
import os
import re
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np
import heyoka as hy

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def model_text(n):
    """models/nbody.lsl with n bodies."""
    text = open(os.path.join(ROOT, "models", "nbody.lsl"), encoding="utf-8").read()
    text, count = re.subn(r"param n = \d+;", f"param n = {n};", text)
    if count != 1:
        sys.exit("nbody_scaling.py: models/nbody.lsl has no single `param n = …;` line")
    return text


def initial(n):
    """The model's point `ring`, as heyoka's state (x, y, z, vx, vy, vz per body)."""
    m = [1 / (i + 1) for i in range(n)]
    state = []
    for i in range(n):
        a = 2 * math.pi * i / n
        state += [2 * math.cos(a), 2 * math.sin(a), 0.1 * (i - 2)]
        state += [0.5 * -math.sin(a), 0.5 * math.cos(a), 0.0]  # p/m
    return m, np.array(state)


def children_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def lasalle(bin, path, t_end, tol, repeat, work, families):
    best_run, best_process, steps = math.inf, math.inf, None
    for _ in range(repeat):
        before = children_cpu()
        out = subprocess.run(
            [bin, "run", path, "-m", "taylor", "--rtol", repr(tol), "--t-end", repr(t_end),
             "--families", families, "--format", "json", "--out", work],
            check=True, capture_output=True, text=True).stdout
        process = children_cpu() - before
        summary = json.loads(out.strip().splitlines()[-1])
        best_run = min(best_run, summary["cpu_seconds"])
        best_process = min(best_process, process)
        steps = summary["steps"]
    out = subprocess.run(
        [bin, "bench-eval", path, "--field", "model", "--lanes", "1,4,8", "--format", "json",
         "--families", families, "--repeat", str(repeat)],
        check=True, capture_output=True, text=True).stdout
    ns = json.loads(out.strip().splitlines()[-1])["ns_per_state"]
    return {"run": best_run, "process": best_process, "steps": steps,
            "eval_ns": ns["1"], "eval_lanes_ns": min(ns["4"], ns["8"])}


def heyoka(n, t_end, tol, repeat):
    m, x0 = initial(n)
    system = hy.model.nbody(n, masses=m, Gconst=1.0)
    build, best_run, steps = None, math.inf, None
    for _ in range(repeat):
        start = time.process_time()
        ta = hy.taylor_adaptive(system, x0, tol=tol, compact_mode=True)
        built = time.process_time()
        outcome = ta.propagate_until(t_end)
        done = time.process_time()
        # the first construction: heyoka caches the compiled code in the process after it
        build = built - start if build is None else build
        best_run = min(best_run, done - built)
        steps = outcome[3]
    variables = [v for v, _ in system]
    cf = hy.cfunc([rhs for _, rhs in system], vars=variables, compact_mode=True)
    states = 1024
    inputs = np.repeat(x0[:, None], states, axis=1) * (1 + 1e-3 * np.linspace(0, 1, states))
    out = np.empty((len(variables), states))
    cf(inputs, outputs=out)  # warm up
    best_eval = math.inf
    for _ in range(repeat):
        calls, start = 0, time.process_time()
        while time.process_time() - start < 0.2:
            cf(inputs, outputs=out)
            calls += 1
        best_eval = min(best_eval, (time.process_time() - start) / (calls * states))
    return {"build": build, "run": best_run, "steps": steps, "eval_ns": best_eval * 1e9}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("bin", help="the lasalle binary")
    parser.add_argument("--sizes", default="3,6,12,24,48,96")
    parser.add_argument("--families", default="loops", choices=["loops", "auto", "unrolled"])
    parser.add_argument("--t-end", type=float, default=1.0)
    parser.add_argument("--tol", type=float, default=1e-15)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as work:
        for n in [int(s) for s in args.sizes.split(",")]:
            path = os.path.join(work, f"nbody{n}.lsl")
            with open(path, "w", encoding="utf-8") as f:
                f.write(model_text(n))
            print(f"N = {n}: lasalle", file=sys.stderr, flush=True)
            a = lasalle(args.bin, path, args.t_end, args.tol, args.repeat, os.path.join(work, "out"),
                        args.families)
            print(f"N = {n}: heyoka", file=sys.stderr, flush=True)
            b = heyoka(n, args.t_end, args.tol, args.repeat)
            rows.append((n, a, b))
    print(f"| bodies N | lasalle: load + run, s | heyoka: construction, s "
          f"| field, ns per state: lasalle (1 / 4–8 per call) | heyoka cfunc (1024 per call) "
          f"| Taylor steps to t = {args.t_end:g}: lasalle / heyoka "
          f"| Taylor µs per step: lasalle / heyoka | ratio |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for n, a, b in rows:
        la, hy_ = a["run"] / a["steps"] * 1e6, b["run"] / b["steps"] * 1e6
        print(f"| {n} | {a['process']:.2f} | {b['build']:.2f} "
              f"| {a['eval_ns']:.0f} / {a['eval_lanes_ns']:.0f} | {b['eval_ns']:.0f} "
              f"| {a['steps']} / {b['steps']} | {la:.1f} / {hy_:.1f} | {la / hy_:.2f} |")


if __name__ == "__main__":
    main()
