#!/usr/bin/env bash
# The demo on the bundled defaults: the product's main job. A scripted teacher shows the robot
# prepareCoffee by kinesthetic demonstration (pour the water, add the coffee, stir with the
# spoon; thesis Fig. 4.14, 5.19); the graph segments it, learns the primitives and the task tree
# (Algorithm 4); then the whole graph (camera, fDED, human observer, DS controller with obstacle
# avoidance, robot manager, attentional supervisor; separate processes over DDS on loopback)
# prepares the coffee with the bottle and the jar moved, judged from the simulated world. It
# prints the per-subtask table beside the thesis's Table 5.5 and where the JSON and the logs are.
#
#   launch_scripts/demo.sh [--walkthrough]
#
# --walkthrough: afterwards, launch_scripts/walkthrough.sh (start the graph and drive it with the
#   `cowork` CLI only: topics, fDED, a motion command, kinesthetic teaching, a bad command).
set -euo pipefail
cd "$(dirname "$0")/.."

walkthrough=
while [[ $# -gt 0 ]]; do
  case "$1" in
    --walkthrough) walkthrough=1; shift ;;
    -h|--help) sed -n '2,13p' "$0"; exit 0 ;;
    *) echo "demo.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done

echo "== building release binaries (first time: a few minutes)"
# cargo's own progress bar on a terminal; its last line otherwise.
if [[ -t 2 ]]; then
  cargo build --release --locked --bins
else
  cargo build --release --locked --bins 2>&1 | tail -n 1
fi

cw=target/release/cowork
out=out/demo
rm -rf "$out/logs" "$out/coffee.json" "$out/report"
mkdir -p "$out"
start=$(date +%s.%N)

echo "== the product's job: a demonstration becomes a task, and the robot carries it out"
echo "   (cowork experiment coffee: teach prepareCoffee by demonstration, then the whole graph"
echo "    prepares it with the bottle and the coffee jar where they never were; half real time)"
# Straight to the terminal, so its progress lines (teaching, then execution) are drawn.
status=0
$cw experiment coffee --trials 1 --seed 1 --rate 0.5 --json "$out/coffee.json" --logs "$out/logs" --report "$out/report" || status=$?
end=$(date +%s.%N)

# Wall time from the start of the demo (after the build) to the supervisor's first action of the
# execution, from its log's UTC timestamps.
first=$(python3 - "$start" "$out/logs/coffee-1/exec/attentional_supervisor.log" <<'EOF'
import datetime, re, sys
start, log = float(sys.argv[1]), sys.argv[2]
try:
    for line in open(log, errors="replace"):
        line = re.sub(r"\x1b\[[0-9;]*m", "", line)
        if "action 1:" in line:
            t = datetime.datetime.strptime(line[:26], "%Y-%m-%dT%H:%M:%S.%f").replace(tzinfo=datetime.timezone.utc)
            print("%.1f s" % (t.timestamp() - start))
            break
    else:
        print("none")
except OSError:
    print("none (no log)")
EOF
)
echo "== done in $(python3 -c "print('%.1f' % ($end - $start))") s wall; first executed action after $first"
echo "   JSON: $out/coffee.json   node logs: $out/logs/coffee-1/{teach,exec}/"
echo "   taught once for the live graph: launch_scripts/teach.sh; then launch_scripts/graph.sh --execute prepareCoffee"

if [[ $status -ne 0 ]]; then
  echo "demo.sh: cowork experiment coffee exited with status $status" >&2
  exit "$status"
fi
if [[ -n $walkthrough ]]; then
  launch_scripts/walkthrough.sh
fi
