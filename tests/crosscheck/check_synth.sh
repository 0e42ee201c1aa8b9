#!/usr/bin/env bash
# `cowork bag synth` against PyPI mcap + mcap-ros2-support: every scenario is synthesised (seed 3,
# short durations) and every message of every bag - these and the sample bags in bags/ - is
# decoded by mcap_ros2.reader.read_ros2_messages; counts per topic are checked against the MCAP
# summary and the stream rates, and field values (image size / encoding, camera intrinsics,
# 11 Xsens segments, joint names, wrench frame, speech words, gesture labels) are checked; the
# kinesthetic demonstrations (pour, coffee, spoon, tea) also by kinpy's forward kinematics of
# their joint states (grasp above the right object, over the cup, tilted or not).
set -euo pipefail
cd "$(dirname "$0")/../.."
: "${VENV:=.venv-crosscheck}"
target="${CARGO_TARGET_DIR:-target}"
# run.sh's own build command (same packages, same features), so a no-op after it.
cargo build --release --locked --bins --examples 2>&1 | tail -n 1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

echo "(a) freshly synthesised bags"
# The kitchen demonstrations other than the pour at their own length (the scripted teacher's
# whole path), without depth frames (as the bundled pour bag).
for spec in "kinesthetic-pour 20" "static-scene 6" "stacking-human 8" "gestures 24" \
    "kinesthetic-coffee 28.5 --no-depth" "kinesthetic-spoon 34.5 --no-depth" "kinesthetic-tea 36.5 --no-depth"; do
  read -r scenario duration flags <<< "$spec"
  start=$(date +%s%N)
  # shellcheck disable=SC2086 # flags are words
  "$target/release/cowork" bag synth "$scenario" -o "$work/$scenario.mcap" --seed 3 --duration "$duration" ${flags:-} > "$work/synth.log"
  ms=$(( ($(date +%s%N) - start) / 1000000 ))
  printf '  %s: %s s of bag, %s bytes, synthesised in %d ms\n' "$scenario" "$duration" \
    "$(stat -c %s "$work/$scenario.mcap")" "$ms"
  "$VENV/bin/python" tests/crosscheck/check_synth.py "$work/$scenario.mcap" "$scenario" "$duration"
done

echo "(b) the sample bags in bags/"
grep -v '^\s*#' bags/bags.txt | while read -r file scenario seed duration flags; do
  [[ -z "$file" ]] && continue
  "$VENV/bin/python" tests/crosscheck/check_synth.py "bags/$file" "$scenario" "$duration"
done
echo "synth cross-check passed"
