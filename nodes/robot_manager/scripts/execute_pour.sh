#!/usr/bin/env bash
# Execution of a taught task in the whole graph (separate processes over DDS, /clock time, real
# time): lwr_sim (depth camera on) + fded_distance + human_observer + ds_controller +
# robot_manager (the taught primitive database) + attentional_supervisor (the learned LTM), with
# the bottle moved to X,Y. Success is judged from /lwr/world (recorded), not from commands.
#
#   nodes/robot_manager/scripts/execute_pour.sh [TEACH_DIR] [X Y] [OUT_DIR] [TIMEOUT_S]
#
# RECORD_EXTRA="/fded/distances /tf" records more topics (for nodes/robot_manager/scripts/damper_census.py).
# TEACH_DIR is what teach_from_bag.sh left (default out/teach-pour). Needs the release binaries.
set -euo pipefail
self="$(cd "$(dirname "$0")" && pwd)/$(basename "$0")"  # to run again under a domain lease
cd "$(dirname "$0")/../../.."
teach=${1:-out/teach-pour}
bx=${2:-0.50}
by=${3:-0.28}
out=${4:-out/execute-pour}
timeout_s=${5:-150}
bin=target/release
for b in lwr_sim fded_distance human_observer ds_controller robot_manager attentional_supervisor cowork; do
  [[ -x $bin/$b ]] || { echo "execute_pour.sh: $bin/$b missing" >&2; exit 1; }
done
[[ -f $teach/learned.schema && -f $teach/primitives/lwr.primitives.json ]] || { echo "teach first (teach_from_bag.sh)" >&2; exit 1; }
rm -rf "$out"
mkdir -p "$out"
cp -r "$teach/primitives" "$out/primitives"
# A DDS domain no other graph on this machine has (yours if ROS_DOMAIN_ID is set), held until the end.
[[ -n ${COWORK_DOMAIN_HELD:-} ]] || exec "$bin/cowork" domain run ${ROS_DOMAIN_ID:+--domain "$ROS_DOMAIN_ID"} --what "execute_pour.sh" -- "$self" "$@"
# The bottle somewhere it never was while taught (same height, upright).
sed "s/name: bottle, \(.*\)pose: { position: \[0.45, 0.35, 0.11\] }/name: bottle, \1pose: { position: [$bx, $by, 0.11] }/" \
  config/scenes/kitchen.yaml > "$out/scene.yaml"
grep -q "\[$bx, $by, 0.11\]" "$out/scene.yaml" || { echo "could not move the bottle in the scene" >&2; exit 1; }
# On a loaded 2-core machine the depth -> fDED chain lags; STALE_S (default 0.3 s) sets the
# controller's watchdog for this trial only.
sed "s/^      stale_after_s: .*$/      stale_after_s: ${STALE_S:-0.3}/" config/ds_controller.yaml > "$out/ds_controller.yaml"
grep -q "^      stale_after_s: ${STALE_S:-0.3}$" "$out/ds_controller.yaml" || { echo "could not set stale_after_s" >&2; exit 1; }
# Obstacle avoidance is on: fded_distance leaves out the bottle the grasp NOA approaches and the
# gripper holds (robot_manager's /manipulated_objects). MODULATION=off turns the modulation off
# (the distances still feed the watchdog), for comparison.
if [[ ${MODULATION:-on} == off ]]; then
  sed -i 's/^        end_effector: true$/        end_effector: false/; s/^        links: true$/        links: false/' "$out/ds_controller.yaml"
  grep -q "end_effector: false" "$out/ds_controller.yaml" || { echo "could not turn the modulation off" >&2; exit 1; }
fi
# SAFETY=off turns ds_controller's link-distance damper off (safety.enabled), for comparison.
if [[ ${SAFETY:-on} == off ]]; then
  sed -i 's/^        enabled: true$/        enabled: false/' "$out/ds_controller.yaml"
  grep -q "^        enabled: false$" "$out/ds_controller.yaml" || { echo "could not turn the link damper off" >&2; exit 1; }
fi
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill -INT "$p" 2>/dev/null || true; done
  for p in "${pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$p" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "$p" 2>/dev/null || true
  done
}
trap cleanup EXIT
$bin/lwr_sim --scene "$out/scene.yaml" --rate 1 >"$out/lwr_sim.log" 2>&1 & pids+=($!)
$bin/fded_distance --params config/fded_distance.yaml --use-sim-time >"$out/fded_distance.log" 2>&1 & pids+=($!)
$bin/human_observer --params config/human_observer.yaml --use-sim-time >"$out/human_observer.log" 2>&1 & pids+=($!)
$bin/ds_controller --params "$out/ds_controller.yaml" --use-sim-time >"$out/ds_controller.log" 2>&1 & pids+=($!)
$bin/cowork bag record -o "$out/run.mcap" /lwr/world /robot_stream /supervisor/action /motion/status /motion/command ${RECORD_EXTRA:-} >"$out/record.log" 2>&1 & pids+=($!)
sleep 3
$bin/robot_manager --use-sim-time --database-dir "$out/primitives" >"$out/robot_manager.log" 2>&1 & pids+=($!)
$bin/attentional_supervisor --ltm "$teach/learned.schema" --task pourDrink --use-sim-time >"$out/attentional_supervisor.log" 2>&1 & pids+=($!)
t0=$(date +%s)
while (( $(date +%s) - t0 < timeout_s )); do
  grep -q "task accomplished" "$out/attentional_supervisor.log" 2>/dev/null && break
  sleep 1
done
sleep 2
cleanup
trap - EXIT
echo "--- actions (robot_manager)"
grep -E "done|failed|interrupted" "$out/robot_manager.log" | sed 's/^.*\(INFO\|WARN\) [a-z_:]*: //' || true
echo "--- supervisor"
grep -E "action [0-9]+:|accomplished|WARN" "$out/attentional_supervisor.log" | sed 's/^.*\(INFO\|WARN\) [a-z_:]*: //' | head -40 || true
