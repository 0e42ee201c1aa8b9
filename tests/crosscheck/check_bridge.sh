#!/usr/bin/env bash
# `cowork bridge` seen by Foxglove's own client packages (tests/crosscheck/bridge/client.js:
# @foxglove/ws-protocol, @foxglove/rosmsg, @foxglove/rosmsg2-serialization, pinned in
# package-lock.json and installed with `npm ci`): lwr_sim (release) and the bridge on this
# check's ROS_DOMAIN_ID; the client decodes /joint_states, /tf, the depth image and the latched
# /robot_description, fetches a mesh asset, and prints the end-to-end latency. The bridge prints
# its own figures (forwarded, msg/s, DDS receive -> queued on the socket) when it stops.
set -euo pipefail
cd "$(dirname "$0")/../.."
: "${ROS_DOMAIN_ID:=78}"
export ROS_DOMAIN_ID
# Node.js (18 or later) and npm come from tests/install-system-deps.sh (Debian `nodejs npm`).
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
  echo "check_bridge: no Node.js/npm; installing them with tests/install-system-deps.sh"
  bash tests/install-system-deps.sh || true
fi
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
  if [[ -n "${CI:-}" ]]; then
    echo "check_bridge: FAILED: Node.js and npm cannot be installed (CI is set)"
    exit 1
  fi
  echo "check_bridge: SKIPPED: no Node.js/npm and they could not be installed (run tests/install-system-deps.sh as root)"
  exit 0
fi
dir=tests/crosscheck/bridge
stamp=$dir/node_modules/.package-lock.sha256
want=$(sha256sum "$dir/package-lock.json" | cut -d' ' -f1)
if [[ ! -f $stamp || "$(cat "$stamp")" != "$want" ]]; then
  echo "npm ci ($dir)"
  (cd "$dir" && npm ci --no-audit --no-fund --loglevel=error)
  echo "$want" > "$stamp"
fi
for b in lwr_sim cowork; do
  [[ -x target/release/$b ]] || { echo "check_bridge: target/release/$b missing (cargo build --release --bins)"; exit 1; }
done

tmp=$(mktemp -d)
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill -INT "$p" 2>/dev/null || true; done
  for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
  rm -rf "$tmp"
}
trap cleanup EXIT
target/release/lwr_sim --rate 1 --duration 90 >"$tmp/lwr_sim.log" 2>&1 &
pids+=($!)
# --port 0: any free port (checks may run beside a graph.sh --bridge on 8765).
target/release/cowork bridge --port 0 --duration 80 --stats-json "$tmp/bridge.json" >"$tmp/bridge.out" 2>"$tmp/bridge.log" &
bridge=$!
pids+=($bridge)
port=
for _ in $(seq 100); do
  port=$(sed -n 's|^cowork bridge: ws://127.0.0.1:\([0-9]*\).*|\1|p' "$tmp/bridge.out")
  [[ -n $port ]] && break
  kill -0 $bridge 2>/dev/null || break
  sleep 0.1
done
if [[ -z $port ]]; then
  echo "check_bridge: the bridge did not start"; cat "$tmp/bridge.out" "$tmp/bridge.log"; exit 1
fi
status=0
node "$dir/client.js" "ws://127.0.0.1:$port" 45 "$tmp/client.json" || status=$?
kill -INT $bridge 2>/dev/null || true
wait $bridge 2>/dev/null || true
echo "bridge (DDS receive -> queued on the WebSocket):"
sed -n '2,$p' "$tmp/bridge.out"
if [[ $status -ne 0 ]]; then
  echo "bridge log:"; tail -n 20 "$tmp/bridge.log"
  echo "lwr_sim log:"; tail -n 20 "$tmp/lwr_sim.log"
fi
exit $status
