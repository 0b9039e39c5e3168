#!/usr/bin/env python3
"""lasalle side by side with heyoka, in one interleaved run.

Measures, on the same machine and in one process tree:

* Kepler (e = 0.8, 1000 periods) and the free rigid body (t = 1000): CPU time (process time of
  the integration only, excluding model compilation on both sides) and the largest final
  invariant error, for heyoka's ``taylor_adaptive`` and lasalle's methods (plain and feedback)
  over a range of tolerances (adaptive methods) or step sizes (fixed-step methods);
* the CPU time per state of the feedback field X - grad V evaluated in batches: heyoka's
  compiled function (``cfunc``) with batch sizes 1, 4 and 8 against lasalle's JIT
  (``lasalle bench-eval``, one state per call and 4 or 8 lanes) and, with ``--native-lanes``,
  the emitted Rust of compiled models built for the host (``-C target-cpu=native``, as heyoka
  compiles for it), 4 and 8 lanes per call (the ``lanes/`` group of ``benches/backends.rs``);

and writes the tables (``docs/heyoka-results.md``), the precision-work diagrams
(``docs/figures/heyoka/precision-work-*.png``) and the raw numbers (``results.json`` in the
work directory). Every measurement is repeated ``--repeat`` times, the repetitions interleaved
over all tasks (heyoka and lasalle alternate), and the fastest is kept.

Run it through ``scripts/heyoka/run.sh``, which makes the virtual environment and builds lasalle.
"""

import argparse
import json
import math
import os
import subprocess
import sys
import time

import heyoka as hy
import numpy as np

KEPLER_PERIOD = 2.0 * math.pi * 5.0**1.5  # a = 5 for x0 = (1,0,0), v0 = (0, sqrt 1.8, 0)


# ---------------------------------------------------------------------------------------------
# The models, written out as in models/*.lsl


def kepler():
    x = hy.make_vars("x0", "x1", "x2")
    v = hy.make_vars("v0", "v1", "v2")
    r = hy.sqrt(x[0] ** 2 + x[1] ** 2 + x[2] ** 2)
    rhs = list(v) + [-xi / r**3 for xi in x]
    lv = cross(x, v)
    inv = {"L": lv, "A": [a - xi / r for a, xi in zip(cross(v, lv), x)]}
    x0 = [1.0, 0.0, 0.0, 0.0, math.sqrt(1.8), 0.0]
    return list(x) + list(v), rhs, inv, {"L": 4.0, "A": 2.0}, x0


def rigid_body():
    R = hy.make_vars(*[f"R{i}{j}" for i in range(3) for j in range(3)])
    om = hy.make_vars("w0", "w1", "w2")
    inertia = [3.0, 2.0, 1.0]
    hat = [[0.0, -om[2], om[1]], [om[2], 0.0, -om[0]], [-om[1], om[0], 0.0]]
    dR = [
        sum_expr(R[3 * i + k] * hat[k][j] for k in range(3) if not is_zero(hat[k][j]))
        for i in range(3)
        for j in range(3)
    ]
    iom = [inertia[i] * om[i] for i in range(3)]
    c = cross(iom, om)
    dom = [c[i] / inertia[i] for i in range(3)]
    C = [
        sum_expr(R[3 * k + i] * R[3 * k + j] for k in range(3)) - (1.0 if i == j else 0.0)
        for i in range(3)
        for j in range(3)
    ]
    E = sum_expr(om[i] * iom[i] for i in range(3)) / 2.0
    pi = [sum_expr(R[3 * i + k] * iom[k] for k in range(3)) for i in range(3)]
    x0 = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0]
    # V = k0/4 |C|^2 + k1/2 (E - E0)^2 + k2/2 |pi - pi0|^2 (models/rigid_body.lsl)
    return list(R) + list(om), dR + dom, {"C": C, "E": [E], "pi": pi}, {"C": 25.0, "E": 100.0, "pi": 50.0}, x0


def perturbed_kepler():
    x = hy.make_vars("x0", "x1", "x2")
    v = hy.make_vars("v0", "v1", "v2")
    mu, delta, e = 1.0, 0.0025, 0.6
    r = hy.sqrt(x[0] ** 2 + x[1] ** 2 + x[2] ** 2)
    U = -mu / r - delta / r**3
    dU = mu / r**2 + 3.0 * delta / r**4
    rhs = list(v) + [-dU * xi / r for xi in x]
    inv = {"E": [sum_expr(vi * vi for vi in v) / 2.0 + U], "L": cross(x, v)}
    x0 = [1.0 - e, 0.0, 0.0, 0.0, math.sqrt((1.0 + e) / (1.0 - e)), 0.0]
    return list(x) + list(v), rhs, inv, {"E": 2.0, "L": 3.0}, x0


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def is_zero(e):
    return isinstance(e, float) and e == 0.0


def sum_expr(terms):
    terms = list(terms)
    out = terms[0]
    for t in terms[1:]:
        out = out + t
    return out


MODELS = {"kepler": kepler, "rigid-body": rigid_body, "perturbed-kepler": perturbed_kepler}


def invariant_values(inv, variables, state):
    """The invariants at `state`, block by block (evaluated by a compiled function)."""
    names = list(inv)
    flat = [e for n in names for e in inv[n]]
    cf = hy.cfunc(flat, vars=variables)
    vals = cf(np.asarray(state, dtype=float))
    out, i = {}, 0
    for n in names:
        out[n] = vals[i : i + len(inv[n])]
        i += len(inv[n])
    return out


def worst_error(inv_fn, x0, x1):
    """max over the invariant blocks of |f(x1) - f(x0)|_2 (Frobenius for the matrix)."""
    a, b = inv_fn(x0), inv_fn(x1)
    return max(float(np.linalg.norm(b[n] - a[n])) for n in a)


# ---------------------------------------------------------------------------------------------
# Integrations


def heyoka_run(ta, x0, t_end):
    ta.state[:] = x0
    ta.time = 0.0
    start = time.process_time()
    res = ta.propagate_until(t_end)
    cpu = time.process_time() - start
    return cpu, int(res[3]), ta.state.copy()


def lasalle_run(exe, model, method, t_end, tol=None, dt=None, gains=None, out_dir="."):
    cmd = [exe, "run", model, "--method", method, "--t-end", repr(t_end)]
    cmd += ["--dt", repr(dt if dt is not None else 0.01), "--every", "1000000000", "--format", "json"]
    cmd += ["--out", os.path.join(out_dir, "lasalle-run")]
    if tol is not None:
        cmd += ["--rtol", repr(tol), "--atol", repr(tol)]
    if gains is not None:
        cmd += ["--gains", gains]
    p = subprocess.run(cmd, capture_output=True, text=True)
    lines = [l for l in p.stdout.splitlines() if l.startswith("{")]
    if not lines:
        return {"failure": (p.stderr.strip() or "no output").splitlines()[-1]}
    s = json.loads(lines[-1])
    errs = [v["final"] for v in s["invariant_errors"].values()]
    err = max(float(e) for e in errs) if all(isinstance(e, (int, float)) for e in errs) else math.nan
    return {
        "cpu": s["cpu_seconds"],
        "steps": s["steps"],
        "error": err,
        # the message without the state it names
        "failure": s["failure"]["message"].split("; state")[0] if s.get("failure") else None,
    }


# ---------------------------------------------------------------------------------------------
# The plan: what to run


TOLS = [1e-6, 1e-8, 1e-10, 1e-12, 1e-14, 1e-15]


def plan(quick):
    """(system, label, kind, parameter) for every integration."""
    tols = [1e-8, 1e-12, 1e-15] if quick else TOLS
    steps = {
        # fixed steps: (euler, rk4) step sizes, each run costs at most ~1e7 steps
        "kepler": ([1e-2, 3e-3] if quick else [1e-2, 3e-3, 1e-3], [2e-2, 5e-3] if quick else [5e-2, 2e-2, 1e-2, 5e-3, 2e-3]),
        "rigid-body": ([1e-2, 1e-3] if quick else [1e-2, 3e-3, 1e-3, 3e-4], [0.1, 0.01] if quick else [0.1, 0.05, 0.02, 0.01, 5e-3, 2e-3]),
    }
    tasks = []
    for system in ["kepler", "rigid-body"]:
        for tol in tols:
            tasks.append((system, "heyoka taylor", "heyoka", tol))
            for m in ["dopri5", "feedback-dopri5", "taylor", "feedback-taylor", "split-taylor"]:
                tasks.append((system, m, "lasalle-tol", tol))
        # below 1e-15 only the Taylor methods (plain Taylor keeps Kepler's invariants to 1e-13
        # from 1e-16 on; DOPRI5 cannot reach it)
        tasks.append((system, "heyoka taylor", "heyoka", 1e-16))
        for m in ["taylor", "split-taylor"]:
            tasks.append((system, m, "lasalle-tol", 1e-16))
        euler_dts, rk4_dts = steps[system]
        for dt in euler_dts:
            for m in ["euler", "feedback-euler"]:
                tasks.append((system, m, "lasalle-dt", dt))
        for dt in rk4_dts:
            for m in ["rk4", "feedback-rk4"]:
                tasks.append((system, m, "lasalle-dt", dt))
    return tasks


def t_end_of(system, periods):
    return periods * KEPLER_PERIOD if system == "kepler" else 1000.0


# ---------------------------------------------------------------------------------------------
# Batched evaluation of X - grad V


def feedback_cfunc(system, batch_size):
    variables, rhs, inv, gains, x0 = MODELS[system]()
    names = list(inv)
    flat_inv = [e for n in names for e in inv[n]]
    # targets f(x0) as parameters, as lasalle passes them at run time
    V, p = 0.0, 0
    for n in names:
        for e in inv[n]:
            V = V + gains[n] / 2.0 * (e - hy.par[p]) ** 2
            p += 1
    fb = [f - hy.diff(V, xi) for f, xi in zip(rhs, variables)]
    cf = hy.cfunc(fb, vars=variables, batch_size=batch_size)
    target = hy.cfunc(flat_inv, vars=variables)(np.asarray(x0, dtype=float))
    return cf, np.asarray(x0, dtype=float), target


EVAL_STATES = 4000  # states per heyoka call, and lasalle's "all states in one call"; not a power
# of two: with a stride of 4096 doubles between the components, loads and stores alias in the L1
# cache (4K aliasing; lasalle k = 4096: 1.6x the time per state of k = 4000)


def heyoka_eval_ns(system, batch_size, n_states, seconds):
    cf, x0, target = feedback_cfunc(system, batch_size)
    n = len(x0)
    scale = 1.0 + 1e-3 * np.arange(n_states) / n_states
    inputs = np.ascontiguousarray(x0[:, None] * scale[None, :])
    pars = np.ascontiguousarray(np.repeat(target[:, None], n_states, axis=1))
    outputs = np.zeros((n, n_states))
    cf(inputs, pars=pars, outputs=outputs)
    sweeps, start = 0, time.process_time()
    while time.process_time() - start < seconds:
        cf(inputs, pars=pars, outputs=outputs)
        sweeps += 1
    return (time.process_time() - start) / (sweeps * n_states) * 1e9


def lasalle_eval_ns(exe, system, seconds):
    cmd = [exe, "bench-eval", system, "--lanes", f"1,4,8,{EVAL_STATES}", "--states", str(EVAL_STATES),
           "--repeat", "1", "--seconds", repr(seconds), "--format", "json"]
    p = subprocess.run(cmd, capture_output=True, text=True, check=True)
    return {int(k): v for k, v in json.loads(p.stdout)["ns_per_state"].items()}


STEMS = {"kepler": "kepler", "rigid-body": "rigid_body", "perturbed-kepler": "perturbed_kepler"}


def native_lanes_ns(bench_exe, system, work):
    """ns per state of the emitted lanes (4 and 8 per call) of `system`, from the criterion
    bench `bench_exe` (benches/backends.rs built for the host), median of one short run."""
    stem = STEMS[system]
    home = os.path.join(work, "criterion-native")
    env = dict(os.environ, CRITERION_HOME=home)
    cmd = [bench_exe, "--bench", f"lanes/{stem}/emitted", "--warm-up-time", "0.5",
           "--measurement-time", "1", "--noplot"]
    subprocess.run(cmd, capture_output=True, text=True, check=True, env=env)
    out = {}
    for k in (4, 8):
        with open(os.path.join(home, f"lanes_{stem}", f"emitted_k{k}", "new", "estimates.json")) as f:
            out[k] = json.load(f)["median"]["point_estimate"] / k
    return out


# ---------------------------------------------------------------------------------------------
# Reports


def fmt(v, spec=".3g"):
    return "—" if v is None or (isinstance(v, float) and math.isnan(v)) else format(v, spec)


def best_of(runs):
    ok = [r for r in runs if r.get("failure") is None and r.get("cpu") is not None]
    if not ok:
        return {"failure": runs[0].get("failure") if runs else "not run"}
    best = min(ok, key=lambda r: r["cpu"])
    return dict(best, repeats=len(ok))


MAX_PLOTTED_ERROR = 10.0  # larger errors (Euler on the rigid body) are left off the diagrams


def figures(results, fig_dir, provisional, periods):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    os.makedirs(fig_dir, exist_ok=True)
    style = {
        "heyoka taylor": ("k", "*", "-"),
        "taylor": ("tab:blue", "o", "-"),
        "feedback-taylor": ("tab:blue", "o", "--"),
        "split-taylor": ("tab:blue", "s", ":"),
        "dopri5": ("tab:orange", "s", "-"),
        "feedback-dopri5": ("tab:orange", "s", "--"),
        "rk4": ("tab:green", "^", "-"),
        "feedback-rk4": ("tab:green", "^", "--"),
        "euler": ("tab:red", "v", "-"),
        "feedback-euler": ("tab:red", "v", "--"),
    }
    paths = []
    for system, title in [("kepler", f"Kepler e = 0.8, {periods:g} periods"), ("rigid-body", "rigid body, t = 1000")]:
        fig, ax = plt.subplots(figsize=(7.5, 5.2))
        for label, (color, marker, ls) in style.items():
            pts = sorted(
                (r["cpu"], max(r["error"], 1e-17), r["param"])
                for r in results
                if r["system"] == system
                and r["label"] == label
                and r.get("failure") is None
                and r["error"] <= MAX_PLOTTED_ERROR
            )
            if not pts:
                continue
            ax.plot([p[0] for p in pts], [p[1] for p in pts], color=color, marker=marker, ls=ls, label=label)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("CPU time of the integration [s]")
        ax.set_ylabel(f"largest final invariant error (≤ {MAX_PLOTTED_ERROR:g} shown)")
        note = " (PROVISIONAL: shared machine)" if provisional else ""
        ax.set_title(f"{title}{note}", fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8, ncol=2)
        fig.tight_layout()
        path = os.path.join(fig_dir, f"precision-work-{system}.png")
        fig.savefig(path, dpi=90)
        plt.close(fig)
        paths.append(path)
    return paths


def markdown(results, evals, args, fig_paths, doc_path):
    lines = []
    lines.append("<!-- generated by scripts/heyoka/bench.py; do not edit by hand -->")
    lines.append("# lasalle vs heyoka: measured numbers\n")
    if args.provisional:
        lines.append("**PROVISIONAL**: measured while other jobs shared the 2-core machine; CPU times are "
                     "noisy. Rerun `scripts/heyoka/run.sh` on a quiet machine.\n")
    lines.append(f"heyoka {hy.__version__}, numpy {np.__version__}, Python {sys.version.split()[0]}; "
                 f"{args.repeat} interleaved repetitions, fastest kept; measured {args.measured}.\n")
    lines.append("Regenerate: `scripts/heyoka/run.sh` (see docs/performance.md).\n")
    for system, tol in [(s, t) for s in ["kepler", "rigid-body"] for t in [1e-15, 1e-16]]:
        lines.append(f"## {system}: tolerance {tol:g}\n")
        lines.append("| method | CPU s | steps | largest final invariant error | CPU / heyoka at 1e-15 |")
        lines.append("| --- | --- | --- | --- | --- |")
        ref = next((r for r in results if r["system"] == system and r["label"] == "heyoka taylor" and r["param"] == 1e-15), None)
        for r in results:
            if r["system"] != system or r["kind"] == "lasalle-dt" or r["param"] != tol:
                continue
            ratio = r["cpu"] / ref["cpu"] if ref and r.get("cpu") and ref.get("cpu") else None
            if r.get("failure"):
                lines.append(f"| {r['label']} | — | — | failed: {r['failure']} | — |")
            else:
                lines.append(f"| {r['label']} | {fmt(r['cpu'])} | {r['steps']} | {fmt(r['error'])} | {fmt(ratio)} |")
        lines.append("")
    lines.append("## Feedback field X − ∇V, CPU ns per state\n")
    lines.append(f"heyoka: one call of the compiled function over {EVAL_STATES} states, batch b = its SIMD "
                 f"width. lasalle (JIT, `lasalle bench-eval`): k states per call, and one call over all "
                 f"{EVAL_STATES} states (the lane loop runs four lanes per iteration as two 128-bit vectors).\n")
    native = any(e.get("native") for e in evals.values())
    if native:
        lines.append("lasalle emitted (host): the emitted Rust lanes of the compiled models, built with "
                     "`-C target-cpu=native` as heyoka compiles for the host (criterion median, "
                     "`benches/backends.rs` group `lanes/`).\n")
    head = f"| model | heyoka batch 1 | heyoka batch 4 | heyoka batch 8 | lasalle 1 | lasalle 4 lanes | lasalle 8 lanes | lasalle {EVAL_STATES} per call |"
    rule = "| --- | --- | --- | --- | --- | --- | --- | --- |"
    if native:
        head += " lasalle emitted (host) 4 lanes | lasalle emitted (host) 8 lanes |"
        rule += " --- | --- |"
    lines += [head, rule]
    for system, e in evals.items():
        h, l = e["heyoka"], e["lasalle"]
        row = f"| {system} | {fmt(h.get(1))} | {fmt(h.get(4))} | {fmt(h.get(8))} | {fmt(l.get(1))} | {fmt(l.get(4))} | {fmt(l.get(8))} | {fmt(l.get(EVAL_STATES))} |"
        if native:
            n = e.get("native", {})
            row += f" {fmt(n.get(4))} | {fmt(n.get(8))} |"
        lines.append(row)
    lines.append("")
    lines.append("## Precision–work diagrams\n")
    for p in fig_paths:
        rel = os.path.relpath(p, os.path.dirname(doc_path))
        lines.append(f"![{os.path.basename(p)}]({rel})\n")
    lines.append("## All runs\n")
    lines.append("| system | method | tol / dt | CPU s | steps | error |")
    lines.append("| --- | --- | --- | --- | --- | --- |")
    for r in results:
        if r.get("failure"):
            lines.append(f"| {r['system']} | {r['label']} | {r['param']:g} | — | — | failed: {r['failure']} |")
        else:
            lines.append(f"| {r['system']} | {r['label']} | {r['param']:g} | {fmt(r['cpu'])} | {r['steps']} | {fmt(r['error'])} |")
    with open(doc_path, "w") as f:
        f.write("\n".join(lines) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--lasalle", required=True, help="path to the lasalle binary (release)")
    ap.add_argument("--work", required=True, help="directory for raw output")
    ap.add_argument("--docs", required=True, help="the repository's docs/ directory")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--periods", type=float, default=1000.0)
    ap.add_argument("--quick", action="store_true", help="fewer tolerances and step sizes")
    ap.add_argument("--provisional", action="store_true", help="mark the figures and tables provisional")
    ap.add_argument("--replot", action="store_true", help="only redraw the docs from WORK/results.json")
    ap.add_argument("--native-lanes", metavar="BENCH_EXE",
                    help="benches/backends.rs built with -C target-cpu=native: time its emitted lanes too")
    args = ap.parse_args()
    os.makedirs(args.work, exist_ok=True)
    if args.replot:
        with open(os.path.join(args.work, "results.json")) as f:
            saved = json.load(f)
        evals = {s: {side: {int(k): v for k, v in d.items()} for side, d in e.items()} for s, e in saved["evals"].items()}
        args.measured, args.repeat = saved["measured"], saved["repeat"]
        write_docs(saved["results"], evals, args)
        return

    args.measured = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    # heyoka integrators, compiled once per (system, tol) before any timing
    tasks = plan(args.quick)
    hey = {}
    for system, label, kind, tol in tasks:
        if kind == "heyoka":
            variables, rhs, inv, _, x0 = MODELS[system]()
            ta = hy.taylor_adaptive(list(zip(variables, rhs)), x0, tol=tol)
            hey[(system, tol)] = (ta, x0, lambda s, inv=inv, v=variables: invariant_values(inv, v, s))

    runs = {i: [] for i in range(len(tasks))}
    evals = {s: {"heyoka": {}, "lasalle": {}, "native": {}} for s in MODELS}
    for rep in range(args.repeat):
        for i, (system, label, kind, param) in enumerate(tasks):
            t_end = t_end_of(system, args.periods)
            if kind == "heyoka":
                ta, x0, inv_fn = hey[(system, param)]
                cpu, steps, x1 = heyoka_run(ta, x0, t_end)
                runs[i].append({"cpu": cpu, "steps": steps, "error": worst_error(inv_fn, x0, x1), "failure": None})
            elif kind == "lasalle-tol":
                gains = "auto" if label.startswith(("feedback", "split")) else None
                runs[i].append(lasalle_run(args.lasalle, system, label, t_end, tol=param, gains=gains, out_dir=args.work))
            else:
                gains = "auto" if label.startswith(("feedback", "split")) else None
                runs[i].append(lasalle_run(args.lasalle, system, label, t_end, dt=param, gains=gains, out_dir=args.work))
            print(f"[{rep + 1}/{args.repeat}] {system} {label} {param:g}: {runs[i][-1]}", flush=True)
        # batched evaluation, interleaved with the integrations
        for system in MODELS:
            for b in (1, 4, 8):
                ns = heyoka_eval_ns(system, b, EVAL_STATES, 0.2)
                evals[system]["heyoka"][b] = min(ns, evals[system]["heyoka"].get(b, math.inf))
            for k, ns in lasalle_eval_ns(args.lasalle, system, 0.2).items():
                evals[system]["lasalle"][k] = min(ns, evals[system]["lasalle"].get(k, math.inf))
            if args.native_lanes:
                for k, ns in native_lanes_ns(args.native_lanes, system, args.work).items():
                    evals[system]["native"][k] = min(ns, evals[system]["native"].get(k, math.inf))
            print(f"[{rep + 1}/{args.repeat}] eval {system}: {evals[system]}", flush=True)

    results = []
    for i, (system, label, kind, param) in enumerate(tasks):
        r = best_of(runs[i])
        r.update(system=system, label=label, kind=kind, param=param)
        results.append(r)
    with open(os.path.join(args.work, "results.json"), "w") as f:
        json.dump({"results": results, "evals": evals, "heyoka": hy.__version__,
                   "measured": args.measured, "repeat": args.repeat}, f, indent=1)
    write_docs(results, evals, args)


def write_docs(results, evals, args):
    fig_paths = figures(results, os.path.join(args.docs, "figures", "heyoka"), args.provisional, args.periods)
    markdown(results, evals, args, fig_paths, os.path.join(args.docs, "heyoka-results.md"))
    print("wrote", os.path.join(args.docs, "heyoka-results.md"), *fig_paths)


if __name__ == "__main__":
    main()
