#!/usr/bin/env bash
# Runs the benchmarks docs/performance.md reports and writes each table into it, between
# `<!-- table: NAME -->` and `<!-- /table -->`; after a run of every table it also rewrites
# the date and machine line between `<!-- measured -->` and `<!-- /measured -->`.
#
#   scripts/performance.sh                      # every table, then the date line (~40 min on 2 cores)
#   scripts/performance.sh taylor-models sweep  # only these tables (the date line is left alone)
#   scripts/performance.sh --list               # the tables and what measures each
#
# Run it on a quiet machine: the numbers are times. `heyoka` (scripts/heyoka/run.sh) writes
# docs/heyoka-results.md and its figures, not a table of this page. Environment:
# LASALLE=path/to/lasalle uses that binary instead of building target/release/lasalle;
# DOC=path writes another copy of the page (default docs/performance.md).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
doc="${DOC:-$root/docs/performance.md}"
target="${CARGO_TARGET_DIR:-$root/target}"
criterion="$target/criterion"
work="$target/performance"
mkdir -p "$work"

all=(feedback paper-runs backends run load load-nbody load-fput load-nbody-loops load-fput-loops family-eval loops-runs feedback-eval nbody-heyoka adaptive-gains taylor-models taylor-kernels sweep heyoka)

describe() {
    case "$1" in
    feedback) echo "cargo bench --bench feedback (generated vs hand-written fields, 10^7 steps)" ;;
    paper-runs) echo "lasalle run kepler|rigid-body -m M against benches/handwritten (fat LTO), 5 interleaved rounds" ;;
    backends) echo "cargo bench --bench backends -- feedback/ (emitted, JIT, interpreter; independent and chained)" ;;
    run) echo "cargo bench --bench backends -- run/ (integrations, emitted vs JIT)" ;;
    load) echo "cargo bench --bench backends -- load/ (loading a model file with the JIT)" ;;
    load-nbody) echo "cargo run --release -p lasalle-exec --example load_scale (N-body load by stage, N = 3 ... 256)" ;;
    load-fput) echo "cargo run --release -p lasalle-exec --example load_scale -- --model fput (FPUT load by stage)" ;;
    load-nbody-loops) echo "load_scale -- --families loops (N-body load with families kept as loops)" ;;
    load-fput-loops) echo "load_scale -- --families loops --model fput (FPUT load with families kept as loops)" ;;
    family-eval) echo "cargo run --release -p lasalle-exec --example family_eval (ns per field evaluation, unrolled vs loops)" ;;
    loops-runs) echo "lasalle run nbody (N = 48, 256) --families loops -m M: load and first run, per method" ;;
    feedback-eval) echo "lasalle bench-eval nbody (N = 12, 48, 96) --families loops|unrolled (ns per X - grad V)" ;;
    nbody-heyoka) echo "scripts/heyoka/nbody_scaling.py (N-body field and Taylor step vs N, lasalle and heyoka compact mode)" ;;
    adaptive-gains) echo "lasalle experiment adaptive-gains (steps and errors; also the figure)" ;;
    taylor-models) echo "lasalle run <model> -m taylor --rtol 1e-15 … --format json, fastest of 5" ;;
    taylor-kernels) echo "cargo bench --bench taylor (emitted Taylor kernels vs the interpreted tape)" ;;
    sweep) echo "lasalle sweep kepler … -m rk4|feedback-rk4|taylor --threads T --lanes L, fastest of 3" ;;
    heyoka) echo "scripts/heyoka/run.sh (writes docs/heyoka-results.md and docs/figures/heyoka/)" ;;
    *) return 1 ;;
    esac
}

if [ "${1:-}" = "--list" ]; then
    for t in "${all[@]}"; do printf '%-15s %s\n' "$t" "$(describe "$t")"; done
    exit 0
fi
selected=("$@")
[ ${#selected[@]} -eq 0 ] && selected=("${all[@]}")
for t in "${selected[@]}"; do
    describe "$t" >/dev/null || { echo "performance.sh: unknown table '$t' (see --list)" >&2; exit 2; }
done

# put_table NAME FILE: the table in FILE replaces the one between NAME's markers in $doc.
put_table() {
    python3 - "$doc" "$1" "$2" <<'EOF'
import re, sys
doc, name, path = sys.argv[1:]
table = open(path, encoding="utf-8").read().strip("\n")
if not table.startswith("|"):
    sys.exit(f"performance.sh: the new '{name}' table is not a markdown table:\n{table}")
text = open(doc, encoding="utf-8").read()
pattern = re.compile(r"(<!-- table: %s -->\n).*?(<!-- /table -->)" % re.escape(name), re.S)
text, n = pattern.subn(lambda m: m.group(1) + table + "\n" + m.group(2), text)
if n != 1:
    sys.exit(f"performance.sh: {doc} has {n} '<!-- table: {name} -->' markers, not one")
open(doc, "w", encoding="utf-8").write(text)
print(f"wrote table '{name}' into {doc}")
EOF
}

# put_date: the date and machine line.
put_date() {
    local cpu
    cpu="$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo 2>/dev/null | head -1)"
    python3 - "$doc" "$(date -u +%F)" "${cpu:-unknown processor}" "$(nproc)" <<'EOF'
import re, sys
doc, day, cpu, cores = sys.argv[1:]
line = (f"Measured on {day} on {cores} cores of an {cpu}, Linux, by `scripts/performance.sh`; "
        "the emitted Rust built for baseline x86-64 (SSE2) unless a table says otherwise.")
text = open(doc, encoding="utf-8").read()
text, n = re.subn(r"(<!-- measured -->).*?(<!-- /measured -->)",
                  lambda m: m.group(1) + line + m.group(2), text, flags=re.S)
if n != 1:
    sys.exit(f"performance.sh: {doc} has {n} '<!-- measured -->' markers, not one")
open(doc, "w", encoding="utf-8").write(text)
EOF
}

# Criterion's median of group/function in ns (the group's '/' become '_' in its directory).
median() {
    python3 - "$criterion" "$1" "$2" <<'EOF'
import json, os, sys
root, group, function = sys.argv[1:]
path = os.path.join(root, group.replace("/", "_"), function, "new", "estimates.json")
print(json.load(open(path))["median"]["point_estimate"])
EOF
}

lasalle_bin() {
    if [ -n "${LASALLE:-}" ]; then
        echo "$LASALLE"
    else
        cargo build --release --quiet >&2
        echo "$target/release/lasalle"
    fi
}

table_feedback() {
    cargo bench --bench feedback >&2
    local fr hr fk hk rg rh
    fr=$(median field/rigid_body prepared); hr=$(median field/rigid_body hand)
    fk=$(median field/kepler prepared); hk=$(median field/kepler hand)
    rg=$(median run/rigid_body_1e7 generated); rh=$(median run/rigid_body_1e7 hand)
    python3 - "$fr" "$hr" "$fk" "$hk" "$rg" "$rh" <<'EOF'
import sys
fr, hr, fk, hk, rg, rh = map(float, sys.argv[1:])
print("| benchmark | generated | hand-written | ratio |")
print("| --- | --- | --- | --- |")
print(f"| rigid-body feedback field, one evaluation | {fr:.1f} ns | {hr:.1f} ns | {fr / hr:.2f} |")
print(f"| Kepler feedback field, one evaluation | {fk:.1f} ns | {hk:.1f} ns | {fk / hk:.2f} |")
print(f"| rigid-body experiment, 10⁷ feedback-Euler steps | {rg / 1e9:.3f} s | {rh / 1e9:.3f} s | {rg / rh:.2f} |")
EOF
}

table_backends() {
    cargo bench --bench backends -- feedback/ --warm-up-time 1 --measurement-time 3 >&2
    python3 - "$criterion" <<'EOF'
import json, os, sys
root = sys.argv[1]
def med(model, f):
    path = os.path.join(root, "feedback_" + model, f, "new", "estimates.json")
    return json.load(open(path))["median"]["point_estimate"]
def ns(x):
    return f"{x:.0f}" if x >= 100 else f"{x:.1f}"
models = sorted(d[len("feedback_"):] for d in os.listdir(root) if d.startswith("feedback_"))
order = ["rigid_body", "kepler", "perturbed_kepler", "cr3bp", "cr3bp_spatial",
         "coupled_oscillators", "duffing", "pendulum_closed_form"]
models = [m for m in order if m in models] + [m for m in models if m not in order]
print("| model | emitted (inlined / call) | JIT, raw call | JIT | interpreter | emitted, chained | JIT, chained | interpreter, chained |")
print("| --- | --- | --- | --- | --- | --- | --- | --- |")
for m in models:
    e, ec, raw, jit, it = (med(m, f) for f in ("emitted", "emitted_call", "jit_raw", "jit", "interpreter"))
    ech, jch, ich = (med(m, f) for f in ("emitted_chained", "jit_chained", "interpreter_chained"))
    print(f"| {m} | {ns(e)} / {ns(ec)} | {ns(raw)} ({raw / ec:.2f}×) | {ns(jit)} ({jit / ec:.2f}×) "
          f"| {ns(it)} ({it / ec:.1f}×) | {ns(ech)} | {ns(jch)} ({jch / ech:.2f}×) | {ns(ich)} ({ich / ech:.1f}×) |")
EOF
}

table_run() {
    cargo bench --bench backends -- run/ >&2
    echo "| run | emitted | JIT | ratio |"
    echo "| --- | --- | --- | --- |"
    for r in rigid_body_1e5 kepler_1e5 rigid_body_dopri5; do
        python3 -c 'import sys; r, e, j = sys.argv[1], float(sys.argv[2]) / 1e6, float(sys.argv[3]) / 1e6
print(f"| {r} | {e:.3g} | {j:.3g} | {j / e:.2f} |")' "$r" "$(median "run/$r" emitted)" "$(median "run/$r" jit)"
    done
}

table_load() {
    cargo bench --bench backends -- load/ >&2
    echo "| model | load (JIT) |"
    echo "| --- | --- |"
    for d in "$criterion"/load/*/; do
        local m
        m="$(basename "$d")"
        [ "$m" = report ] && continue
        python3 -c 'import sys; print(f"| {sys.argv[1]} | {float(sys.argv[2]) / 1e6:.2g} |")' "$m" "$(median load "$m")"
    done
}

# The load of a family by stage, sizes in processes of their own; sizes past the one that took
# longer than LOAD_LIMIT seconds (default 300) are skipped.
table_load_nbody() {
    cargo run --release --quiet -p lasalle-exec --example load_scale -- \
        --limit "${LOAD_LIMIT:-300}" 3 6 12 24 48 96 128 256
}

table_load_fput() {
    cargo run --release --quiet -p lasalle-exec --example load_scale -- \
        --model fput --limit "${LOAD_LIMIT:-300}" 16 32 64 128 256 512 1024 2048 4096
}

table_load_nbody_loops() {
    cargo run --release --quiet -p lasalle-exec --example load_scale -- \
        --families loops 3 6 12 24 48 96 128 256
}

table_load_fput_loops() {
    cargo run --release --quiet -p lasalle-exec --example load_scale -- \
        --families loops --model fput 16 32 64 128 256 512 1024 2048 4096
}

table_family_eval() {
    cargo run --release --quiet -p lasalle-exec --example family_eval -- 12 24 48 96
    echo
    cargo run --release --quiet -p lasalle-exec --example family_eval -- --model fput 64 256 1024 4096
}

# models/nbody.lsl with N bodies, in $work
nbody_file() {
    sed "s/param n = 5;/param n = $1;/" models/nbody.lsl >"$work/nbody$1.lsl"
    echo "$work/nbody$1.lsl"
}

# the N-body family with its families as loops: the load (the report's load_seconds) and the
# whole process (wall clock) of a first run of 10 steps of each method that needs a derived
# function (X - grad V, the half-fields, Df for the projection)
table_loops_runs() {
    local bin file t0 t1 json
    bin="$(lasalle_bin)"
    echo "| bodies N | method | load s | whole run s (wall) |"
    echo "| --- | --- | --- | --- |"
    for n in 48 256; do
        file="$(nbody_file "$n")"
        for m in feedback-euler feedback-rk4 stormer-verlet-b projection-rk4; do
            t0=$(date +%s.%N)
            json=$("$bin" run "$file" -m "$m" --dt 1e-5 --t-end 1e-4 --families loops \
                --format json --out "$work/loops-run")
            t1=$(date +%s.%N)
            python3 -c 'import json, sys
d = json.loads(sys.argv[4])
assert d["failure"] is None, d["failure"]
load = d["load_seconds"]
print(f"| {sys.argv[1]} | {sys.argv[2]} | {load:.3f} | {float(sys.argv[3]):.2f} |")' \
                "$n" "$m" "$(python3 -c "print($t1 - $t0)")" "$json"
        done
    done
}

# one evaluation of X - grad V with the families as loops and unrolled (bench-eval, JIT, CPU)
table_feedback_eval() {
    local bin file loops unrolled
    bin="$(lasalle_bin)"
    echo "| bodies N | unrolled ns | loops ns | loops / unrolled |"
    echo "| --- | --- | --- | --- |"
    for n in 12 48 96; do
        file="$(nbody_file "$n")"
        loops=$("$bin" bench-eval "$file" --families loops --lanes 1 --repeat 3 --format json)
        unrolled=$("$bin" bench-eval "$file" --families unrolled --lanes 1 --repeat 3 --format json)
        python3 -c 'import json, sys
l, u = (json.loads(a)["ns_per_state"]["1"] for a in sys.argv[2:])
print(f"| {sys.argv[1]} | {u:.0f} | {l:.0f} | {l / u:.2f} |")' "$n" "$loops" "$unrolled"
    done
}

table_adaptive_gains() {
    local bin out="$work/adaptive-gains"
    bin="$(lasalle_bin)"
    "$bin" experiment adaptive-gains --out "$out" -q >&2
    cp "$out/adaptive-gains-rigid-body-energy.png" "$root/docs/figures/"
    grep '^|' "$out/summary.md"
}

# model and end time T of the Taylor runs
taylor_runs=(
    "kepler 70248.1" "rigid_body 1000" "cr3bp 10000" "cr3bp_spatial 3000" "perturbed_kepler 3000"
    "so3_type_i 3000" "so3_type_iia 3000" "so3_type_iib 3000" "so3_type_iii 3000"
    "coupled_oscillators 10000" "duffing 30000" "pendulum_closed_form 3000"
)

table_taylor_models() {
    local bin
    bin="$(lasalle_bin)"
    echo "| model | T | steps | CPU s |"
    echo "| --- | --- | --- | --- |"
    for r in "${taylor_runs[@]}"; do
        set -- $r
        for _ in 1 2 3 4 5; do
            "$bin" run "models/$1.lsl" -m taylor --rtol 1e-15 --atol 1e-15 --dt 0.01 \
                --every 1000000000 --format json --t-end "$2" --out "$work/taylor-$1"
        done | python3 -c 'import json, sys
runs = [json.loads(l) for l in sys.stdin if l.startswith("{")]
steps = {r["steps"] for r in runs}
assert len(runs) == 5 and len(steps) == 1, "five runs with the same steps"
cpu = min(r["cpu_seconds"] for r in runs)
print(f"| {sys.argv[1]} | {sys.argv[2]} | {steps.pop()} | {cpu:.3g} |")' "$1" "$2"
    done
}

# The paper's fixed-step runs from the model files against the same runs written by hand
# (benches/handwritten: fixed-size arrays, fat LTO, one codegen unit), five interleaved rounds,
# the fastest of each: the run's CPU (`cpu_seconds`: the integration and its recording) and the
# whole process's (loading, the run, writing the outputs).
table_paper_runs() {
    local bin hand
    bin="$(lasalle_bin)"
    cargo build --release --quiet --manifest-path benches/handwritten/Cargo.toml \
        --target-dir "$target/handwritten" >&2
    hand="$target/handwritten/release/handwritten-runs"
    python3 - "$bin" "$hand" "$work" <<'EOF'
import json, os, resource, subprocess, sys
bin, hand, work = sys.argv[1:]
# model, step, steps, samples of the invariants' errors (every `steps / samples` steps)
models = [("kepler", 0.005, 1_404_962, 20_071), ("rigid-body", 1e-4, 1_000_000, 20_000)]
methods = ["euler", "rk4", "feedback-euler", "feedback-rk4"]

def process_cpu(cmd):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, json.loads(out.strip().splitlines()[-1])

print("| model | method | steps | hand-written, ns/step | lasalle run, ns/step | ratio | process CPU, hand-written / lasalle | final states agree to |")
print("| --- | --- | --- | --- | --- | --- | --- | --- |")
for model, h, steps, samples in models:
    for method in methods:
        best = {"hand": (1e9, 1e9), "lasalle": (1e9, 1e9)}
        states = {}
        for _ in range(5):
            cpu, r = process_cpu([hand, model, method, str(steps), str(samples)])
            best["hand"] = min(best["hand"], (r["cpu_seconds"], cpu))
            states["hand"] = r["final_state"]
            cpu, r = process_cpu([bin, "run", model, "-m", method, "--dt", repr(h),
                                  "--t-end", repr(steps * h), "--every", str(steps // samples),
                                  "--format", "json", "--out", os.path.join(work, "paper-run")])
            assert r["steps"] == steps, (model, method, r["steps"])
            best["lasalle"] = min(best["lasalle"], (r["cpu_seconds"], cpu))
            states["lasalle"] = r["final_state"]
        agree = max(abs(a - b) / max(1.0, abs(b)) for a, b in zip(states["lasalle"], states["hand"]))
        (hr, hp), (lr, lp) = best["hand"], best["lasalle"]
        print(f"| {model} | {method} | {steps} | {hr / steps * 1e9:.1f} | {lr / steps * 1e9:.1f} "
              f"| {lr / hr:.2f} | {hp:.3f} s / {lp:.3f} s | {agree:.0e} |")
EOF
}

table_taylor_kernels() {
    cargo bench --bench taylor | tee /dev/stderr | python3 -c 'import re, sys
rows = {}
for line in sys.stdin:
    m = re.match(r"^(.*?)\s+(emitted|tape)\s+([0-9.]+) s\s+(\d+) steps", line)
    if m:
        rows.setdefault(m.group(1), {})[m.group(2)] = float(m.group(3))
print("| run | emitted kernels | interpreted tape |")
print("| --- | --- | --- |")
for what, t in rows.items():
    emitted, tape = t["emitted"], t["tape"]
    print(f"| {what} | {emitted:.2g} | {tape:.2g} |")'
}

# wall seconds of the fastest of 3 sweeps
sweep_time() {
    local bin="$1" method="$2" threads="$3" lanes="$4" best="" t0 t1 t step=(--dt 0.001)
    # the Taylor method's steps are its own, at the tolerance
    [ "$method" = taylor ] && step=(--rtol 1e-15 --atol 1e-15)
    for _ in 1 2 3; do
        t0=$(date +%s.%N)
        "$bin" sweep kepler -m "$method" "${step[@]}" --t-end 70.2481 --grid 'v[1]=1.2:1.4:128' \
            --threads "$threads" --lanes "$lanes" --out "$work/sweep.csv" >/dev/null
        t1=$(date +%s.%N)
        t=$(python3 -c "print($t1 - $t0)")
        best=$(python3 -c "print(min(float('$t'), float('${best:-inf}')))")
    done
    echo "$best"
}

# heyoka from PyPI in the virtual environment scripts/heyoka/run.sh makes
heyoka_python() {
    local venv="$root/target/heyoka-venv"
    if [ ! -x "$venv/bin/python" ]; then
        python3 -m venv "$venv" >&2
        "$venv/bin/pip" install --quiet "heyoka>=7" numpy matplotlib >&2
    fi
    echo "$venv/bin/python"
}

table_nbody_heyoka() {
    "$(heyoka_python)" scripts/heyoka/nbody_scaling.py "$(lasalle_bin)" --sizes "${NBODY_SIZES:-3,6,12,24,48,96}" \
        --families "${NBODY_FAMILIES:-loops}"
}

table_sweep() {
    local bin
    bin="$(lasalle_bin)"
    echo "| method | 1 thread, no lanes | 1 thread, 8 lanes | 2 threads, no lanes | 2 threads, 8 lanes |"
    echo "| --- | --- | --- | --- | --- |"
    for method in rk4 feedback-rk4 taylor; do
        python3 -c 'import sys
m, a, b, c, d = sys.argv[1], *map(float, sys.argv[2:])
print(f"| {m} | {a:.2f} | {b:.2f} ({a / b:.1f}×) | {c:.2f} ({a / c:.1f}×) | {d:.2f} ({a / d:.1f}×) |")' \
            "$method" "$(sweep_time "$bin" "$method" 1 1)" "$(sweep_time "$bin" "$method" 1 8)" \
            "$(sweep_time "$bin" "$method" 2 1)" "$(sweep_time "$bin" "$method" 2 8)"
    done
}

for t in "${selected[@]}"; do
    echo "== $t: $(describe "$t")" >&2
    if [ "$t" = heyoka ]; then
        scripts/heyoka/run.sh
        continue
    fi
    "table_${t//-/_}" >"$work/$t.md"
    put_table "$t" "$work/$t.md"
done
if [ ${#selected[@]} -eq ${#all[@]} ]; then
    put_date
    echo "updated the date line of $doc" >&2
else
    echo "note: a partial run: the date line of $doc is unchanged" >&2
fi
