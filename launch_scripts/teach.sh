#!/usr/bin/env bash
# Teach the kitchen tasks once, from demonstrations, and keep what was learned: the LTM with the
# learned subtasks and the robot manager's primitive database that
# `launch_scripts/graph.sh --execute TASK` runs.
#
#   launch_scripts/teach.sh [--out DIR]      (default: config/learned)
#
# Every demonstration is a kinesthetic bag (a scripted teacher pushing the arm with wrenches and
# saying teach / done / gripper ...): bags/kinesthetic-pour.mcap is bundled (seed 1); add(coffee)
# and use(spoon) are synthesised here with `cowork bag synth --seed 1 --after ...` (same seed,
# same bytes), each starting where the previous demonstration left the arm and the objects.
# prepareCoffee (Fig. 4.14, 5.19) is taught in one session by `cowork teach` in the graph
# (lwr_sim, robot_manager, attentional_supervisor as processes over DDS): pour, coffee, spoon
# one after the other, `teach` once, `done` once. Its add(water) is pourDrink's whole task, so
# the one LTM executes both (graph.sh --execute pourDrink | prepareCoffee).
# The result replaces DIR only when the task was taught completely.
set -euo pipefail
cd "$(dirname "$0")/.."

out=config/learned
while [[ $# -gt 0 ]]; do
  case "$1" in
    --out) out="$2"; shift 2 ;;
    -h|--help) sed -n '2,17p' "$0"; exit 0 ;;
    *) echo "teach.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done

cw=target/release/cowork
[[ -x $cw ]] || { echo "teach.sh: $cw missing; run: cargo build --release --bins" >&2; exit 1; }
work=$(mktemp -d "${TMPDIR:-/tmp}/cowork-teach.XXXXXX")
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/learned"

echo "== synthesising add(coffee) and use(spoon) after bags/kinesthetic-pour.mcap (seed 1)"
"$cw" bag synth kinesthetic-coffee -o "$work/kinesthetic-coffee.mcap" --seed 1 --no-depth \
  --after kinesthetic-pour >/dev/null
"$cw" bag synth kinesthetic-spoon -o "$work/kinesthetic-spoon.mcap" --seed 1 --no-depth \
  --after kinesthetic-pour --after kinesthetic-coffee >/dev/null

echo "== prepareCoffee from the three demonstrations"
"$cw" teach --task prepareCoffee --bag bags/kinesthetic-pour.mcap \
  --bag "$work/kinesthetic-coffee.mcap" --bag "$work/kinesthetic-spoon.mcap" \
  --ltm config/tasks/kitchen.schema --ltm-out "$work/learned/kitchen.learned.schema" \
  --database-dir "$work/learned/primitives" --logs "$work/logs/prepareCoffee"

# Replace the old result in one step: a failed teaching above leaves it untouched.
mkdir -p "$(dirname "$out")"
rm -rf "$out.new"
cp -r "$work/learned" "$out.new"
rm -rf "$out.old"
[[ -d $out ]] && mv "$out" "$out.old"
mv "$out.new" "$out"
rm -rf "$out.old"
echo "learned LTM and primitives in $out/"
