#!/usr/bin/env bash
# Interop with an independent DDS implementation (Cyclone DDS, Python binding): lwr_sim's
# /joint_states are received with ROS 2 names and types, and a velocity command published by
# Cyclone moves the simulated joints.
set -euo pipefail
cd "$(dirname "$0")/../.."
: "${VENV:=.venv-crosscheck}"
: "${ROS_DOMAIN_ID:=77}"
export ROS_DOMAIN_ID
export CYCLONEDDS_URI="file://$PWD/tests/crosscheck/cyclonedds-loopback.xml"
log=$(mktemp)
target/release/lwr_sim --rate 1 --duration 60 >"$log" 2>&1 &
sim=$!
trap 'kill -INT $sim 2>/dev/null || true; wait $sim 2>/dev/null || true; rm -f "$log"' EXIT
status=0
"$VENV/bin/python" tests/crosscheck/dds_peer.py "$ROS_DOMAIN_ID" || status=$?
if [[ $status -ne 0 ]]; then
  echo "lwr_sim log:"; tail -n 20 "$log"
fi
exit $status
