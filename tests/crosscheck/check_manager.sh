#!/usr/bin/env bash
# cowork_manager against movement_primitives (PyPI, CartesianDMP): every NOA learned from the pour
# bag by `cowork primitives learn` (position + orientation DMP in the object's frame) and the
# reference Cartesian DMP fitted on the same segment with the same gains, both rolled out open
# loop; ours must reproduce the demonstration as well (within 1 mm / 1 deg).
set -euo pipefail
cd "$(dirname "$0")/../.."
: "${VENV:=.venv-crosscheck}"
target="${CARGO_TARGET_DIR:-target}"
cargo build --release --locked --bins --examples 2>&1 | tail -n 1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$target/release/cowork" primitives learn --bag bags/kinesthetic-pour.mcap --export "$work" > "$work/learn.txt"
grep -E '^[0-9]+ ' "$work/learn.txt"
"$VENV/bin/python" tests/crosscheck/check_manager.py "$work"
