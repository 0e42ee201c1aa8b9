#!/usr/bin/env bash
# DDS Security in CI (issue #19): two cowork processes secured with a keystore from
# `cowork keystore` exchange /speech_command while an independent Cyclone DDS peer without
# credentials floods the same topic (stranger.py's `secure` mode). Passes when, with
# ROS_SECURITY_STRATEGY=Enforce, the stranger gets 0 messages through and the member's do
# arrive; without security both arrive (so the check can tell). Builds the secured peer with
# `--features cowork_ros/security` (RustDDS's security plugins: openssl, ring), and first runs
# cowork_ros's security tests with the feature (two secured processes talk; a peer without our
# credentials and one with another CA's keystore get nothing through).
set -euo pipefail
cd "$(dirname "$0")/../.."
if ! out=$(RUST_BACKTRACE=0 cargo test --release --locked -p cowork_ros --features security --test security -- --nocapture 2>&1); then
  echo "$out" | grep -v -E "^\s+(Compiling|Finished|Running)" | tail -n 60
  echo "FAIL: cowork_ros security tests (--features security)"
  exit 1
fi
echo "$out" | grep -E "^test |test result|^secured talker"
# Built last and run from a copy of its own: a CI rehearsal once found target/release/examples/
# secure_peer without the feature by the time the check ran.
cargo build --release --locked -p cowork_ros --features security --example secure_peer 2>&1 | tail -n 1
peer_dir=$(mktemp -d)
trap 'rm -rf "$peer_dir"' EXIT
cp target/release/examples/secure_peer "$peer_dir/secure_peer"
SECURE_PEER="$peer_dir/secure_peer" bash tests/crosscheck/check_stranger.sh --secure
