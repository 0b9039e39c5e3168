#!/usr/bin/env bash
# lasalle side by side with heyoka: makes a virtual environment with heyoka and matplotlib
# from PyPI under target/heyoka-venv (outside the crate's dependencies; nothing is installed
# system-wide), builds lasalle in release mode and runs scripts/heyoka/bench.py, which writes
# docs/heyoka-results.md and docs/figures/heyoka/*.png (raw numbers in target/heyoka-bench/).
#
#   scripts/heyoka/run.sh                  # the full run, for a quiet machine
#   scripts/heyoka/run.sh --provisional    # mark the output provisional (shared machine)
#   scripts/heyoka/run.sh --quick          # fewer tolerances and step sizes
#   scripts/heyoka/run.sh --no-native      # without the emitted lanes built for the host
#
# Unless --no-native is given, the lanes benchmark of compiled models (benches/backends.rs) is
# also built with -C target-cpu=native (under target/native, a few minutes the first time) and
# its emitted lanes are timed next to heyoka's batches. Other arguments go to bench.py
# (--repeat N, --periods P, …).
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
cd "$root"
target="${CARGO_TARGET_DIR:-$root/target}"
venv="$root/target/heyoka-venv"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
    "$venv/bin/pip" install --quiet "heyoka>=7" numpy matplotlib
fi
cargo build --release --quiet
args=()
native=1
for a in "$@"; do
    if [ "$a" = "--no-native" ]; then native=0; else args+=("$a"); fi
done
if [ "$native" = 1 ]; then
    bench_exe="$(RUSTFLAGS="-C target-cpu=native" CARGO_TARGET_DIR="$root/target/native" \
        cargo bench --bench backends --no-run --message-format=json 2>/dev/null |
        "$venv/bin/python" -c 'import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m.get("executable") and m["target"]["name"] == "backends":
        print(m["executable"])')"
    args+=(--native-lanes "$bench_exe")
fi
"$venv/bin/python" scripts/heyoka/bench.py \
    --lasalle "$target/release/lasalle" \
    --work "$root/target/heyoka-bench" \
    --docs "$root/docs" ${args[@]+"${args[@]}"}
