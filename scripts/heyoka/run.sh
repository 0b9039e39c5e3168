#!/usr/bin/env bash
# lasalle side by side with heyoka: makes a virtual environment with heyoka and matplotlib
# from PyPI under target/heyoka-venv (outside the crate's dependencies; nothing is installed
# system-wide), builds lasalle in release mode and runs scripts/heyoka/bench.py, which writes
# docs/heyoka-results.md and docs/figures/heyoka/*.png (raw numbers in target/heyoka-bench/).
#
#   scripts/heyoka/run.sh                  # the full run, for a quiet machine
#   scripts/heyoka/run.sh --provisional    # mark the output provisional (shared machine)
#   scripts/heyoka/run.sh --quick          # fewer tolerances and step sizes
#
# Extra arguments go to bench.py (--repeat N, --periods P, …).
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
"$venv/bin/python" scripts/heyoka/bench.py \
    --lasalle "$target/release/lasalle" \
    --work "$root/target/heyoka-bench" \
    --docs "$root/docs" "$@"
