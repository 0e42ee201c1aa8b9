#!/usr/bin/env bash
# The demo on the bundled defaults: teach pourDrink by demonstration and let the whole graph carry
# it out; then start the graph and drive it with the `cowork` CLI only, as a user without ROS
# would. Everything stays on loopback.
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== building release binaries (first time: a few minutes)"
cargo build --release --locked --bins 2>&1 | tail -n 1

cw=target/release/cowork

echo "== the product's job: a demonstration becomes a task, and the robot carries it out"
echo "   (cowork experiment pouring: a scripted teacher pushes the arm through pourDrink, the graph"
echo "    segments and learns it, then the whole graph - camera, fDED, avoidance - pours with the"
echo "    bottle somewhere else; judged from the simulated world)"
$cw experiment pouring --trials 1 --seed 1 --json out/demo/pouring.json --logs out/demo/logs 2>&1 | sed 's/^/  /'
echo "  (JSON: out/demo/pouring.json; taught once for graph.sh --execute: launch_scripts/teach.sh)"

export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$(( 30 + RANDOM % 60 ))}"
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
$cw say teach

echo "== kinesthetic teaching: a person pushes the tool with 20 N along -z for 1.5 s (eq. 4.6)"
$cw topic pub /external_wrench geometry_msgs/msg/WrenchStamped \
  '{"wrench": {"force": {"x": 0, "y": 0, "z": -20}}}' --rate 50 --count 75 --wait 5
tool

echo "== gripper: close (grasps the nearest object within 5 cm, if any)"
$cw topic pub /lwr/gripper_command std_msgs/msg/String '{"data": "close"}' --wait 5
grep -h "gripper" "$logs/lwr_sim.log" | tail -n 1 | sed 's/^/  lwr_sim: /'

$cw say done
grep -h "segment\|teach" "$logs/robot_manager.log" | tail -n 3 | sed 's/^/  robot_manager: /'

echo "== a bad command (6 values) is rejected and the robot is held"
$cw topic pub /lwr/joint_velocity_command std_msgs/msg/Float64MultiArray '{"data": [1, 1, 1, 1, 1, 1]}' --wait 5
sleep 0.5
grep -h "rejected" "$logs/lwr_sim.log" | tail -n 1 | sed 's/^/  lwr_sim: /'

echo "== stopping the graph"
