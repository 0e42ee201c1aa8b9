#!/usr/bin/env bash
# Teach a task once, from demonstrations, and keep what was learned: the LTM with the learned
# subtasks and the robot managers' primitive databases that `launch_scripts/graph.sh --execute
# TASK` runs.
#
#   launch_scripts/teach.sh [--task prepareCoffee|pizza] [--out DIR]
#       (default prepareCoffee into config/learned; pizza into config/learned-pizza)
#
# prepareCoffee: every demonstration is a kinesthetic bag (a scripted teacher pushing the arm
# with wrenches and saying teach / done / gripper ...): bags/kinesthetic-pour.mcap is bundled
# (seed 1); add(coffee) and use(spoon) are synthesised here with `cowork bag synth --seed 1
# --after ...` (same seed, same bytes), each starting where the previous demonstration left the
# arm and the objects. prepareCoffee (Fig. 4.14, 5.19) is taught in one session by `cowork
# teach` in the graph (lwr_sim, robot_manager, attentional_supervisor as processes over DDS):
# pour, coffee, spoon one after the other, `teach` once, `done` once. Its add(water) is
# pourDrink's whole task, so the one LTM executes both (graph.sh --execute pourDrink |
# prepareCoffee).
# pizza (Sec. 5.2.4): the dual-arm pizza topping taught by imitation, as `cowork experiment
# pizza` teaches it: an Xsens demonstrator (`cowork bag synth pizza-demo-left|right --seed 1
# --vary-teacher`) does the whole task once with each arm, each in its teaching scene; one LTM
# with both arms' subtasks, one primitive database per arm (graph.sh --scene
# config/scenes/pizza.yaml --arms "left right" --execute pizza).
# The result replaces DIR only when the task was taught completely.
set -euo pipefail
cd "$(dirname "$0")/.."

out=
task=prepareCoffee
while [[ $# -gt 0 ]]; do
  case "$1" in
    --out) out="$2"; shift 2 ;;
    --task) task="$2"; shift 2 ;;
    -h|--help) sed -n '2,23p' "$0"; exit 0 ;;
    *) echo "teach.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done
case "$task" in
  prepareCoffee) out=${out:-config/learned} ;;
  pizza) out=${out:-config/learned-pizza} ;;
  *) echo "teach.sh: --task $task: expected prepareCoffee or pizza" >&2; exit 2 ;;
esac

cw=target/release/cowork
[[ -x $cw ]] || { echo "teach.sh: $cw missing; run: cargo build --release --bins" >&2; exit 1; }
work=$(mktemp -d "${TMPDIR:-/tmp}/cowork-teach.XXXXXX")
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/learned"

if [[ $task == pizza ]]; then
  ltm=config/tasks/pizza.schema
  for arm in left right; do
    echo "== the $arm arm: synthesising the demonstration (pizza-demo-$arm, seed 1), teaching it by imitation"
    "$cw" bag synth "pizza-demo-$arm" -o "$work/pizza-demo-$arm.mcap" --seed 1 --no-depth --vary-teacher >/dev/null
    "$cw" teach --arms "left right" --task pizza --bag "$work/pizza-demo-$arm.mcap" \
      --ltm "$ltm" --ltm-out "$work/pizza.learned-$arm.schema" \
      --database-dir "$work/learned/primitives" --scene "config/scenes/pizza-teach-$arm.yaml" \
      --logs "$work/logs/pizza-$arm"
    ltm=$work/pizza.learned-$arm.schema
  done
  cp "$ltm" "$work/learned/pizza.learned.schema"
else
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
fi

# Replace the old result in one step: a failed teaching above leaves it untouched.
mkdir -p "$(dirname "$out")"
rm -rf "$out.new"
cp -r "$work/learned" "$out.new"
rm -rf "$out.old"
[[ -d $out ]] && mv "$out" "$out.old"
mv "$out.new" "$out"
rm -rf "$out.old"
echo "learned LTM and primitives in $out/"
