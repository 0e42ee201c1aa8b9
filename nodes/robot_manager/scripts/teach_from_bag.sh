#!/usr/bin/env bash
# Teaching from a kinesthetic bag in the running graph (separate processes over DDS, /clock time):
# lwr_sim moves under the bag's /external_wrench, robot_manager relays `gripper close|open` to
# /lwr/gripper_command and segments online, attentional_supervisor attaches the segments
# (Algorithm 4) and saves the learned LTM.
#
#   nodes/robot_manager/scripts/teach_from_bag.sh [BAG] [OUT_DIR] [TASK]
#
# Defaults: bags/kinesthetic-pour.mcap, out/teach-pour, pourDrink. Needs the release binaries
# (cargo build --release -p lwr_sim -p robot_manager -p attentional_supervisor -p cowork).
# Leaves OUT_DIR/primitives/lwr.primitives.json, OUT_DIR/learned.schema and OUT_DIR/*.log.
set -euo pipefail
self="$(cd "$(dirname "$0")" && pwd)/$(basename "$0")"  # to run again under a domain lease
cd "$(dirname "$0")/../../.."
bag=${1:-bags/kinesthetic-pour.mcap}
out=${2:-out/teach-pour}
task=${3:-pourDrink}
bin=target/release
for b in lwr_sim robot_manager attentional_supervisor cowork; do
  [[ -x $bin/$b ]] || { echo "teach_from_bag.sh: $bin/$b missing" >&2; exit 1; }
done
rm -rf "$out"
mkdir -p "$out"
# A DDS domain no other graph on this machine has (yours if ROS_DOMAIN_ID is set), held until the end.
[[ -n ${COWORK_DOMAIN_HELD:-} ]] || exec "$bin/cowork" domain run ${ROS_DOMAIN_ID:+--domain "$ROS_DOMAIN_ID"} --what "teach_from_bag.sh" -- "$self" "$@"
# No depth camera: nothing here reads it, and rendering would load the machine.
sed 's/^      enabled: true/      enabled: false/' config/lwr_sim.yaml > "$out/lwr_sim.yaml"
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill -INT "$p" 2>/dev/null || true; done
  for p in "${pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$p" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "$p" 2>/dev/null || true
  done
}
trap cleanup EXIT
$bin/lwr_sim --params "$out/lwr_sim.yaml" --rate 1 >"$out/lwr_sim.log" 2>&1 & pids+=($!)
$bin/robot_manager --use-sim-time --database-dir "$out/primitives" >"$out/robot_manager.log" 2>&1 & pids+=($!)
$bin/attentional_supervisor --ltm config/tasks/kitchen.schema --task "$task" --use-sim-time \
  --save-ltm "$out/learned.schema" >"$out/attentional_supervisor.log" 2>&1 & pids+=($!)
sleep 2
start=$(date +%s.%N)
$bin/cowork bag play "$bag" --topics /external_wrench /speech_command --clock-hz 0 --delay 2 --wait-readers 20 --quiet
end=$(date +%s.%N)
sleep 2
cleanup
trap - EXIT
echo "replayed $bag in $(echo "$end - $start" | bc) s wall (ROS_DOMAIN_ID=$ROS_DOMAIN_ID)"
echo "--- segments (robot_manager)"
grep -o 'segment [a-z]*[0-9]*([a-z]*) ([A-Za-z]*) [0-9.]*–[0-9.]* s' "$out/robot_manager.log" || true
echo "--- warnings (robot_manager)"
grep -i 'warn' "$out/robot_manager.log" | sed 's/^.*WARN //' || true
echo "--- learned (attentional_supervisor)"
grep -E 'learned |WARN' "$out/attentional_supervisor.log" | sed 's/^.*INFO //' || true
echo "--- $out/learned.schema (learned part)"
grep -A12 'learned from demonstration' "$out/learned.schema" || echo "(no learned schema saved)"
