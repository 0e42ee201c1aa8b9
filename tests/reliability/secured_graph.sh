#!/usr/bin/env bash
# The stranger's one successful attack against the whole graph, without and with DDS security:
# an independent Cyclone DDS peer without credentials floods /lwr/joint_velocity_command
# (0.5 rad/s on joints 1 and 2, 100 Hz; stranger.py `flood`) for the whole of one pourDrink
# trial (`cowork experiment pouring`: taught, executed, judged from the simulated world). Run
# once unsecured, once with every process in its own enclave and ROS_SECURITY_STRATEGY=Enforce.
# Needs the nodes and cowork built with security:
#   cargo build --release --bins -p lwr_sim -p fded_distance -p human_observer -p ds_controller \
#       -p robot_manager -p attentional_supervisor -p cowork --features cowork_ros/security
#   VENV=.venv-crosscheck bash tests/reliability/secured_graph.sh [SEED]
# ATTACK=assault: every attack class of the stranger check in turn instead (stranger.py
# `assault`: malformed and direct joint commands, bad distances, human state, speech, DMPs,
# model_file tricks, /clock jumps, wrong types), blind, for the whole trial. RUNS="yes" runs
# only the secured trial (default "no yes"). POLICY=1: the nodes' enclaves grant only the
# topics config/security/policy.xml gives each node.
set -euo pipefail
cd "$(dirname "$0")/../.."
: "${VENV:=.venv-crosscheck}"
: "${ROS_DOMAIN_ID:=163}"
export ROS_DOMAIN_ID CYCLONEDDS_URI="file://$PWD/tests/crosscheck/cyclonedds-loopback.xml"
seed=${1:-1}
attack=${ATTACK:-flood}
out=$(mktemp -d /tmp/cowork-secured-graph-XXXX)
ks=$out/keystore
target/release/cowork keystore create "$ks" >/dev/null
nodes=(lwr_sim fded_distance human_observer ds_controller robot_manager attentional_supervisor)
if [[ -n "${POLICY:-}" ]]; then
  # Each node only the topics config/security/policy.xml grants it; the runner (the test
  # harness: it speaks, moves the person, records) every topic.
  target/release/cowork keystore enclave "$ks" "${nodes[@]}" --policy config/security/policy.xml >/dev/null
  target/release/cowork keystore enclave "$ks" cowork_teach cowork_experiment >/dev/null
else
  target/release/cowork keystore enclave "$ks" "${nodes[@]}" cowork_teach cowork_experiment >/dev/null
fi
for secured in ${RUNS:-no yes}; do
  env=()
  [[ $secured == yes ]] && env=(ROS_SECURITY_ENABLE=true ROS_SECURITY_STRATEGY=Enforce ROS_SECURITY_KEYSTORE="$ks")
  # COWORK_ALLOW_STRANGERS: the unsecured trial must meet the attack, not refuse the stranger.
  env "${env[@]}" COWORK_ALLOW_STRANGERS=1 target/release/cowork experiment pouring --trials 1 --seed "$seed" --rate 1 \
    --time-limit 120 --json "$out/pouring-$secured.json" > "$out/pouring-$secured.txt" 2>&1 &
  trial=$!
  "$VENV/bin/python" tests/crosscheck/stranger.py 0 "$attack" 400 "$trial" > "$out/stranger-$secured.txt" 2>&1 &
  flood=$!
  wait "$trial" || true
  kill "$flood" 2>/dev/null || true
  wait "$flood" 2>/dev/null || true
  echo "== security: $secured"
  grep -E "^pouring seed|tool:|person \(" "$out/pouring-$secured.txt" || tail -n 5 "$out/pouring-$secured.txt"
  grep -E "tool speed above|success" "$out/pouring-$secured.txt" | tail -n 3
  cat "$out/stranger-$secured.txt"
done
echo "outputs in $out"
