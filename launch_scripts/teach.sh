#!/usr/bin/env bash
# Teach the kitchen tasks once, from demonstrations, and keep what was learned: the LTM with the
# learned subtasks and the robot manager's primitive database that
# `launch_scripts/graph.sh --execute TASK` runs.
#
#   launch_scripts/teach.sh [--out DIR]      (default: config/learned)
#
# Every demonstration is a kinesthetic bag (a scripted teacher pushing the arm with wrenches and
# saying teach / done / gripper ...): bags/kinesthetic-pour.mcap is bundled; the others are
# synthesised here with `cowork bag synth` (same seed, same bytes). Each task is taught by
# `cowork teach` in the graph (lwr_sim, robot_manager, attentional_supervisor as processes over
# DDS); the LTM of one task is the starting point of the next, so what was learned is reused.
# The result replaces DIR only when every task was taught.
set -euo pipefail
cd "$(dirname "$0")/.."

out=config/learned
while [[ $# -gt 0 ]]; do
  case "$1" in
    --out) out="$2"; shift 2 ;;
    -h|--help) sed -n '2,14p' "$0"; exit 0 ;;
    *) echo "teach.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done

cw=target/release/cowork
[[ -x $cw ]] || { echo "teach.sh: $cw missing; run: cargo build --release --bins" >&2; exit 1; }
work=$(mktemp -d "${TMPDIR:-/tmp}/cowork-teach.XXXXXX")
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/learned"

echo "== pourDrink from bags/kinesthetic-pour.mcap"
"$cw" teach --task pourDrink --bag bags/kinesthetic-pour.mcap \
  --ltm config/tasks/kitchen.schema --ltm-out "$work/learned/kitchen.learned.schema" \
  --database-dir "$work/learned/primitives" --logs "$work/logs/pourDrink"

# Replace the old result in one step: a failed teaching above leaves it untouched.
mkdir -p "$(dirname "$out")"
rm -rf "$out.new"
cp -r "$work/learned" "$out.new"
rm -rf "$out.old"
[[ -d $out ]] && mv "$out" "$out.old"
mv "$out.new" "$out"
rm -rf "$out.old"
echo "learned LTM and primitives in $out/"
