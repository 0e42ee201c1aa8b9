#!/usr/bin/env bash
# The stranger test (issue #19): an independent Cyclone DDS peer (stranger.py) attacks the
# running graph — lwr_sim, fded_distance, human_observer, ds_controller as separate release
# processes on a private domain with the bundled parameters and lwr_sim's simulated clock — while
# a person stands close to the arm and the arm runs a task. Prints per attack class the messages
# sent, the nodes alive after, the largest tool / joint speed and whether it got through, then two
# chaos cases (fded_distance stopped and continued, then killed and restarted); fails on a dead node or an attack that moved the arm faster
# than the person's presence allows.
#
#   tests/crosscheck/run.sh stranger
#   ROS_DOMAIN_ID=150 bash tests/crosscheck/check_stranger.sh [chaos]   (chaos: the full chaos table)
#   STRANGER_ONLY="human state" ... (one attack class);  STRANGER_LOGS=1 ... (the nodes' logs)
#   bash tests/crosscheck/check_stranger.sh --secure   (DDS Security: the stranger, without
#     credentials, floods a topic between two secured cowork processes -> "N sent, 0 through";
#     needs target/release/cowork and, built with the security feature,
#     cargo build --release -p cowork_ros --features security --example secure_peer)
set -euo pipefail
cd "$(dirname "$0")/../.."
: "${VENV:=.venv-crosscheck}"
: "${ROS_DOMAIN_ID:=78}"
export CYCLONEDDS_URI="file://$PWD/tests/crosscheck/cyclonedds-loopback.xml"
mode="${1:-check}"
exec "$VENV/bin/python" tests/crosscheck/stranger.py "$ROS_DOMAIN_ID" "${mode#--}"
