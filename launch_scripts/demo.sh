#!/usr/bin/env bash
# The demo on the bundled defaults: start the graph, then drive it with the `cowork` CLI only,
# as a user without ROS would. Everything stays on loopback.
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== building release binaries (first time: a few minutes)"
cargo build --release --locked --bins 2>&1 | tail -n 1

export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$(( 30 + RANDOM % 60 ))}"
cw=target/release/cowork
logs=out/logs
echo "== starting the graph on ROS_DOMAIN_ID=$ROS_DOMAIN_ID (logs in $logs/)"
launch_scripts/graph.sh --logs "$logs" &
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

echo "== topics seen over DDS"
$cw topic list --wait 3 | sed 's/^/  /'

echo "== start pose"
joints; tool

echo "== fDED: closest obstacle per link from the depth camera (/fded/distances)"
$cw topic echo /fded/distances -n 1 --wait 20 |
  python3 -c 'import json,sys; m=json.load(sys.stdin); i=m["min_index"]; l=m["links"][i] if i >= 0 else None
print("  backend %s, processing %.1f ms; " % (m["backend"], 1e3 * m["processing_time"]) + ("closest: %s at %.3f m" % (l["link_name"], l["distance"]) if l else "no obstacle in view"))'

echo "== joint velocity command: joint 1 at 0.3 rad/s for 2 s (re-sent at 50 Hz)"
$cw topic pub /lwr/joint_velocity_command std_msgs/msg/Float64MultiArray \
  '{"data": [0.3, 0, 0, 0, 0, 0, 0]}' --rate 50 --count 100 --wait 5
joints

echo "== kinesthetic teaching: a person pushes the tool with 20 N along -z for 1.5 s (eq. 4.6)"
$cw topic pub /external_wrench geometry_msgs/msg/WrenchStamped \
  '{"wrench": {"force": {"x": 0, "y": 0, "z": -20}}}' --rate 50 --count 75 --wait 5
tool

echo "== gripper: close (grasps the nearest object within 5 cm, if any)"
$cw topic pub /lwr/gripper_command std_msgs/msg/String '{"data": "close"}' --wait 5
grep -h "gripper" "$logs/lwr_sim.log" | tail -n 1 | sed 's/^/  lwr_sim: /'

echo "== a bad command (6 values) is rejected and the robot is held"
$cw topic pub /lwr/joint_velocity_command std_msgs/msg/Float64MultiArray '{"data": [1, 1, 1, 1, 1, 1]}' --wait 5
sleep 0.5
grep -h "rejected" "$logs/lwr_sim.log" | tail -n 1 | sed 's/^/  lwr_sim: /'

echo "== stopping the graph"
