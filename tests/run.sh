#!/usr/bin/env bash
# The test command of the README (and of .ci/run): the Rust test suite of the whole workspace,
# then the cross-check group against independent implementations (Python, from PyPI).
#
#   tests/run.sh            everything
#   tests/run.sh --core     only `cargo test` (fast, no Python)
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== cargo test --workspace"
cargo test --workspace --locked

if [[ "${1:-}" == "--core" ]]; then
  exit 0
fi

echo "== cross-checks (tests/crosscheck)"
tests/crosscheck/run.sh
