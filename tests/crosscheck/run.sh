#!/usr/bin/env bash
# Cross-check group: compares cowork with independent implementations from PyPI.
#
#   tests/crosscheck/run.sh [NAME...]     run check_NAME.sh (all when none named)
#
# Creates (or reuses) a virtual environment at $VENV (default .venv-crosscheck), installs every
# tests/crosscheck/requirements-*.txt into it, builds the release binaries the checks use, and
# runs each check in a fresh DDS domain so checks never see each other's nodes.
set -euo pipefail
cd "$(dirname "$0")/../.."
export VENV="${VENV:-$PWD/.venv-crosscheck}"

python=${PYTHON:-python3}
if [[ ! -x "$VENV/bin/python" ]]; then
  echo "creating $VENV"
  "$python" -m venv "$VENV"
fi
stamp="$VENV/.requirements.sha256"
want=$(cat tests/crosscheck/requirements-*.txt 2>/dev/null | sha256sum | cut -d' ' -f1)
if [[ ! -f "$stamp" || "$(cat "$stamp")" != "$want" ]]; then
  "$VENV/bin/python" -m pip install --quiet --upgrade pip
  for r in tests/crosscheck/requirements-*.txt; do
    echo "pip install -r $r"
    "$VENV/bin/python" -m pip install --quiet -r "$r"
  done
  echo "$want" > "$stamp"
fi

echo "building release binaries"
cargo build --release --locked --bins --examples 2>&1 | tail -n 2

if [[ $# -gt 0 ]]; then
  checks=()
  for n in "$@"; do checks+=("tests/crosscheck/check_$n.sh"); done
else
  checks=(tests/crosscheck/check_*.sh)
fi

# check_stranger.sh (issue #19) is one of them: a foreign DDS peer attacks the running graph.
passed=0
failed=0
failed_names=()
for c in "${checks[@]}"; do
  name=$(basename "$c" .sh)
  echo "---- $name"
  # Each check on a DDS domain no other graph on this machine has (ROS_DOMAIN_ID set for it).
  if target/release/cowork domain run --what "crosscheck $name" -- bash "$c"; then
    passed=$((passed + 1))
  else
    failed=$((failed + 1))
    failed_names+=("$name")
  fi
done
if [[ $failed -gt 0 ]]; then
  echo "failed: ${failed_names[*]}"
fi
echo "crosscheck: $passed passed, $failed failed"
[[ $failed -eq 0 ]]
