#!/usr/bin/env bash
# cowork_msgs against rosbags (PyPI): our .msg texts and full ros2msg definitions parse, the
# standard types equal rosbags' ROS 2 Jazzy definitions, and CDR bytes are identical both ways
# for random samples of every message type.
set -euo pipefail
cd "$(dirname "$0")/../.."
: "${VENV:=.venv-crosscheck}"
target="${CARGO_TARGET_DIR:-target}"
codec="$target/release/examples/msg_codec"
# run.sh's own build command (same packages, same features), so a no-op after it.
cargo build --release --locked --bins --examples 2>&1 | tail -n 1
"$VENV/bin/python" tests/crosscheck/check_msgs.py "$codec" "${MSGS_SEED:-20241122}"
