#!/usr/bin/env bash
# The pour taught once, executed from five bottle positions it never saw (taught at
# (0.45, 0.35)), in the whole graph with obstacle avoidance and the link damper on (the bundled
# ds_controller parameters, watchdog STALE_S as in execute_pour.sh), one trial each; judged from
# the recorded /lwr/world (judge_pour.py) and printed as a table beside thesis Table 5.4.
#
#   nodes/robot_manager/scripts/pour_positions.sh [TEACH_DIR] [OUT_DIR] [TIMEOUT_S]
#
# TEACH_DIR holds primitives/lwr.primitives.json and learned.schema, e.g. what the graph test
# leaves with COWORK_TEACH_OUT=out/teach-graph cargo test -p cowork_graph_tests --test teach_execute_pour
# (or teach_from_bag.sh). Needs the release binaries and .venv-crosscheck (mcap_ros2, PyYAML:
# tests/crosscheck/run.sh creates it). Real time: about 20-40 s per position on a quiet machine.
# POSITIONS="0.55,0.40 0.38,0.38" runs only those; each run records /fded/distances and /tf too,
# for damper_census.py.
set -euo pipefail
cd "$(dirname "$0")/../../.."
teach=${1:-out/teach-graph}
out=${2:-out/pour-positions}
timeout_s=${3:-120}
py=${PYTHON:-.venv-crosscheck/bin/python}
[[ -x $py ]] || { echo "pour_positions.sh: $py missing (tests/crosscheck/run.sh creates .venv-crosscheck)" >&2; exit 1; }
mkdir -p "$out"
positions=("0.50 0.28" "0.40 0.32" "0.55 0.40" "0.48 0.22" "0.38 0.38")
if [[ -n ${POSITIONS:-} ]]; then
  positions=()
  for p in $POSITIONS; do positions+=("${p/,/ }"); done
fi
export RECORD_EXTRA=${RECORD_EXTRA-/fded/distances /tf}
for p in "${positions[@]}"; do
  read -r x y <<<"$p"
  echo "--- bottle at ($x, $y), load $(cut -d' ' -f1-3 /proc/loadavg)" >&2
  nodes/robot_manager/scripts/execute_pour.sh "$teach" "$x" "$y" "$out/$x-$y" "$timeout_s" >"$out/$x-$y.txt" 2>&1 || true
  "$py" nodes/robot_manager/scripts/judge_pour.py "$out/$x-$y/run.mcap" >"$out/$x-$y.json" 2>"$out/$x-$y.judge.err" || true
  # Damper activity of the trial (status lines of ds_controller's log, on change).
  grep -c "approach limited" "$out/$x-$y/ds_controller.log" >"$out/$x-$y.damper" 2>/dev/null || echo 0 >"$out/$x-$y.damper"
  # Watchdog holds (data late: the machine's load, not the task).
  grep -c "stale" "$out/$x-$y/ds_controller.log" >"$out/$x-$y.stale" 2>/dev/null || echo 0 >"$out/$x-$y.stale"
done
"$py" - "$out" "${positions[@]}" <<'EOF'
import json, statistics, sys
out, positions = sys.argv[1], sys.argv[2:]
rows, ok = [], 0
times = {"take_s": [], "pour_s": [], "add_s": []}
print("| bottle at (m) | success (world) | take(water) s | pour(water) s | add(water) s | max tilt over the cup (deg) | released at (m) | damper / stale-hold status lines | failed actions |")
print("|---|---|---|---|---|---|---|---|---|")
for p in positions:
    x, y = p.split()
    try:
        j = json.load(open(f"{out}/{x}-{y}.json"))
    except Exception as e:  # no recording, judge failed
        print(f"| ({x}, {y}) | **no** (no judgement: {e}) | | | | | | | |")
        continue
    damper = open(f"{out}/{x}-{y}.damper").read().strip() + " / " + open(f"{out}/{x}-{y}.stale").read().strip()
    w = j.get("world_times", {})
    ok += bool(j["success"])
    if j["success"]:
        for k in times:
            if w.get(k) is not None:
                times[k].append(w[k])
    f = lambda v: "—" if v is None else f"{v:.1f}"
    failed = "; ".join(f"{l}: {r}" for l, r in j.get("failed", [])) or "—"
    print(f"| ({x}, {y}) | {'yes' if j['success'] else '**no**'} | {f(w.get('take_s'))} | {f(w.get('pour_s'))} | {f(w.get('add_s'))} "
          f"| {j.get('max_tilt_over_cup_deg', 0):.1f} | ({j['bottle_end'][0]:.3f}, {j['bottle_end'][1]:.3f}) | {damper} | {failed} |")
med = lambda v: f"{statistics.median(v):.1f}" if v else "—"
print()
print(f"{ok} / {len(positions)} successful.")
print()
print("| subtask | here: median of the successful trials (s) | thesis Table 5.4 execution (s) | thesis teaching (s) |")
print("|---|---|---|---|")
for k, name, thesis, teach in [("take_s", "take(water)", 31.0, 20.1), ("pour_s", "pour(water)", 46.5, 30.3), ("add_s", "add(water)", 77.5, 50.4)]:
    print(f"| {name} | {med(times[k])} | {thesis} | {teach} |")
sys.exit(0 if ok == len(positions) else 1)
EOF
