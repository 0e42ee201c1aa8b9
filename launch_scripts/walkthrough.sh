#!/usr/bin/env bash
# A walk through the running graph with the `cowork` CLI only, as a user without ROS would:
# start the graph (launch_scripts/graph.sh: every node its own process, DDS on loopback, one log
# per node in out/demo/graph/logs/, a fresh teaching state), list its nodes and topics, read
# /joint_states, fDED's distances and the human observer's /human/state, send ds_controller a
# constant-speed motion (/motion/command, reported on /motion/status), say `teach`, push the arm
# with an external wrench (kinesthetic teaching, eq. 4.6), close the gripper, say `done`, show a
# bad command rejected, and stop the graph cleanly.
#
#   launch_scripts/walkthrough.sh        (launch_scripts/demo.sh --walkthrough runs it after the demo)
#
# Needs the release binaries (cargo build --release --bins). ROS_DOMAIN_ID: yours, else a free one
# (`cowork domain run`: no other graph on this machine has it while the walkthrough runs).
set -euo pipefail
self="$(cd "$(dirname "$0")" && pwd)/$(basename "$0")"  # to run again under a domain lease
cd "$(dirname "$0")/.."

cw=target/release/cowork
[[ -x $cw ]] || { echo "walkthrough.sh: $cw missing; run: cargo build --release --bins" >&2; exit 1; }

[[ -n ${COWORK_DOMAIN_HELD:-} ]] || exec "$cw" domain run ${ROS_DOMAIN_ID:+--domain "$ROS_DOMAIN_ID"} --what "launch_scripts/walkthrough.sh" -- "$self" "$@"
logs=out/demo/graph/logs
# A fresh teaching state: what an earlier run taught (out/) must not change what the demo shows.
rm -rf out/demo/graph
echo "== starting the graph on ROS_DOMAIN_ID=$ROS_DOMAIN_ID (logs in $logs/)"
launch_scripts/graph.sh --logs "$logs" --state out/demo/graph &
graph=$!
# TERM, not INT: a background job of a non-interactive shell ignores SIGINT.
trap 'kill -TERM $graph 2>/dev/null || true; wait $graph 2>/dev/null || true' EXIT

joints() { # prints joint positions in deg
  $cw topic echo /joint_states -n 1 --wait 10 |
    python3 -c 'import json,sys,math; m=json.load(sys.stdin); print("  q [deg] =", [round(math.degrees(v),1) for v in m["position"]])'
}
tool() {
  q=$($cw topic echo /joint_states -n 1 --wait 10 | python3 -c 'import json,sys; print(",".join(repr(v) for v in json.load(sys.stdin)["position"]))')
  $cw robot fk --joints "$q" | python3 -c 'import json,sys; m=json.load(sys.stdin); print("  tool position [m] =", [round(v,3) for v in m["position"]])'
}

# `cowork say` publishes once the first listener matched its new participant; a listener matched
# later misses the word (volatile topic). Say it again when robot_manager's log lacks it.
say() { # word...
  local n
  n=$(grep -c "speech: \"$*\"" "$logs/robot_manager.log" || true)
  $cw say "$@"
  for _ in $(seq 20); do
    [[ $(grep -c "speech: \"$*\"" "$logs/robot_manager.log" || true) -gt $n ]] && return 0
    sleep 0.1
  done
  echo "  (robot_manager missed \"$*\": saying it again)"
  $cw say "$@"
}

echo "== nodes and topics seen over DDS"
$cw node list --wait 3 | sed 's/^/  /'
$cw topic list --wait 1 | sed 's/^/  /'
$cw topic info /fded/distances --wait 1 | sed 's/^/  /'

echo "== start pose"
joints; tool

echo "== fDED: closest obstacle per link from the depth camera (/fded/distances)"
$cw topic echo /fded/distances -n 1 --wait 20 |
  python3 -c 'import json,sys; m=json.load(sys.stdin); i=m["min_index"]; l=m["links"][i] if i >= 0 else None
print("  backend %s, processing %.1f ms; " % (m["backend"], 1e3 * m["processing_time"]) + ("closest: %s at %.3f m" % (l["link_name"], l["distance"]) if l else "no obstacle in view"))'

echo "== the person: human_observer's /human/state (nobody tracked: present false, far speed)"
$cw topic echo /human/state -n 1 --wait 10 |
  python3 -c 'import json,sys; m=json.load(sys.stdin); print("  present %s, mode %s, speed scale %.2f m/s, stopped %s" % (m["present"], ["far","interaction"][m["mode"]], m["speed_scale"], m["stopped"]))'

echo "== DS controller: move the tool 10 cm along +y at 0.3 m/s (/motion/command, constant speed)"
goal=$($cw topic echo /joint_states -n 1 --wait 10 | python3 -c 'import json,sys; print(",".join(repr(v) for v in json.load(sys.stdin)["position"]))' |
  xargs -I{} $cw robot fk --joints {} | python3 -c 'import json,sys; p=json.load(sys.stdin)["position"]; print(json.dumps({"x": p[0], "y": p[1] + 0.1, "z": p[2]}))')
$cw topic pub /motion/command cowork_msgs/msg/MotionCommand \
  "{\"id\": 1, \"kind\": 1, \"label\": \"demo reach\", \"goal\": {\"position\": $goal, \"orientation\": {\"w\": 1}}, \"nominal_speed\": 0.3, \"hold_orientation\": true}" --wait 5
sleep 3
$cw topic echo /motion/status -n 1 --wait 10 |
  python3 -c 'import json,sys; m=json.load(sys.stdin); e=m["goal_error"]
print("  /motion/status: command %d %s %s" % (m["command_id"], ["running","converged","aborted","held"][m["state"]], m["reason"]) + ("" if e is None else ", %.3f m from the goal" % e))'
tool

echo "== teaching: say teach (robot_manager lets the arm go and segments what the person shows)"
say teach

echo "== kinesthetic teaching: a person pushes the tool with 20 N along -z for 1.5 s (eq. 4.6)"
$cw topic pub /external_wrench geometry_msgs/msg/WrenchStamped \
  '{"wrench": {"force": {"x": 0, "y": 0, "z": -20}}}' --rate 50 --count 75 --wait 5
tool

echo "== gripper: close (grasps the nearest object within 5 cm, if any)"
$cw topic pub /lwr/gripper_command std_msgs/msg/String '{"data": "close"}' --wait 5
grep -h "gripper" "$logs/lwr_sim.log" | tail -n 1 | sed 's/^/  lwr_sim: /'

say done
grep -h "segment\|teach" "$logs/robot_manager.log" | tail -n 3 | sed 's/^/  robot_manager: /'

echo "== a bad command (6 values) is rejected and the robot is held"
$cw topic pub /lwr/joint_velocity_command std_msgs/msg/Float64MultiArray '{"data": [1, 1, 1, 1, 1, 1]}' --wait 5
sleep 0.5
grep -h "rejected" "$logs/lwr_sim.log" | tail -n 1 | sed 's/^/  lwr_sim: /'

echo "== stopping the graph"
