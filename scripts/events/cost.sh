#!/usr/bin/env bash
# The cost of events per step: Hénon–Heiles (models/henon_heiles.lsl, one event) integrated
# with and without its event, same method and steps, CPU time per step, best of 5 runs.
#   scripts/events/cost.sh [path/to/lasalle]     (default: target/release/lasalle)
set -euo pipefail
bin=${1:-target/release/lasalle}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cp models/henon_heiles.lsl "$work/with.lsl"
grep -v '^    event ' models/henon_heiles.lsl > "$work/without.lsl"
best() { # best CPU seconds per step of 5 runs: model, then run flags
    local model=$1; shift
    for _ in 1 2 3 4 5; do
        "$bin" run "$model" "$@" --init chaotic --out "$work/out" --every 1000000 --format json
    done | python3 -c '
import json, sys
runs = [json.loads(l) for l in sys.stdin]
print(min(r["cpu_seconds"] / r["steps"] for r in runs), runs[0]["steps"],
      runs[0]["events"]["counts"].get("section", 0))'
}
printf '%-18s %10s %12s %12s %10s %9s\n' method steps "ns/step" "+event" "extra" crossings
for spec in "rk4 --dt 0.01" "stormer-verlet-b --dt 0.01" "dopri5 --rtol 1e-10 --atol 1e-10" "taylor --rtol 1e-14"; do
    read -r -a flags <<< "-m $spec"
    read -r base steps _ <<< "$(best "$work/without.lsl" "${flags[@]}" --t-end 20000)"
    read -r with _ crossings <<< "$(best "$work/with.lsl" "${flags[@]}" --t-end 20000)"
    python3 -c "
b, w = $base * 1e9, $with * 1e9
print(f'{\"${spec%% *}\":<18} {$steps:>10} {b:>12.1f} {w:>12.1f} {w - b:>+9.1f}  {$crossings:>8}')"
done
