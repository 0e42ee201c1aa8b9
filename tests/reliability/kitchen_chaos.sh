#!/usr/bin/env bash
# Chaos in the kitchen graph (issue #19): a pourDrink trial (`cowork experiment pouring`:
# taught from a synthesised demonstration, executed by the whole graph with a person passing
# by, judged from the simulated world) once per fault, each node of the executing graph in turn
# killed (SIGKILL, started again after 2 s) or stopped (SIGSTOP, continued after 2 s), from 8 s
# (simulated) after the robot's first action on, once the tool moves. Prints one table: when the robot was held, how
# far it moved, when it moved again, and whether the task still completed.
#
#   bash tests/reliability/kitchen_chaos.sh [SEED]          # 11 faults, ~1 min wall each
#   FAULTS="robot_manager:kill lwr_sim:stop" bash tests/reliability/kitchen_chaos.sh 2
#
# Needs the release binaries (cargo build --release --bins). Results: out/chaos/SEED/*.json.
set -euo pipefail
cd "$(dirname "$0")/../.."
seed=${1:-1}
faults=${FAULTS:-"lwr_sim:stop fded_distance:kill fded_distance:stop human_observer:kill human_observer:stop ds_controller:kill ds_controller:stop robot_manager:kill robot_manager:stop attentional_supervisor:kill attentional_supervisor:stop"}
out=out/chaos/$seed
mkdir -p "$out"
for f in $faults; do
  name=${f/:/-}
  echo "== $f (seed $seed)"
  target/release/cowork experiment pouring --trials 1 --seed "$seed" --rate 1 --fault "$f" \
    --json "$out/$name.json" --logs "$out/logs-$name" > "$out/$name.txt" 2>&1 || true
  grep -E "^pouring seed|fault:" "$out/$name.txt" || tail -n 5 "$out/$name.txt"
done
python3 - "$out" $faults <<'EOF'
import json, sys, os
out, faults = sys.argv[1], sys.argv[2:]
print("\n| fault (2 s) | during | tool m/s then | held after s | tool path m | joints off rad | moving again after s | task | pourDrink s |")
print("|---|---|---|---|---|---|---|---|---|")
for f in faults:
    p = os.path.join(out, f.replace(":", "-") + ".json")
    try:
        t = json.load(open(p))["trials"][0]
    except (OSError, ValueError, KeyError, IndexError) as e:
        print(f"| {f} | – | – | – | – | – | – | no result ({e}) | – |")
        continue
    o = t.get("fault") or {}
    num = lambda v, d=2: "–" if v is None else f"{v:.{d}f}"
    task = "completed" if t["success"] else "FAILED: " + t["reason"][:120]
    print(f"| {f} | {o.get('during') or '–'} | {num(o.get('tool_speed_m_s'), 3)} | {num(o.get('held_after_s'))} | {num(o.get('tool_path_m'), 3)} | "
          f"{num(o.get('joint_excursion_rad'), 3)} | {num(o.get('resumed_after_s'))} | {task} | {num(t.get('duration_s'), 1)} |")
EOF
