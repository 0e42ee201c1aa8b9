#!/usr/bin/env bash
# Start the cowork graph: every node a separate process, talking DDS on loopback.
#
#   launch_scripts/graph.sh [--rate R | --max] [--duration S] [--logs DIR] [--scene FILE]
#                           [--execute TASK [--learned DIR]] [--teach TASK] [--state DIR]
#                           [--bridge [--bridge-port PORT]] [--arms "left right"] [--domain N|auto]
#
# DDS domain: ROS_DOMAIN_ID (default 0), or --domain N, or --domain auto (a free one, printed).
#   The graph holds it for its life (`cowork domain run`): a second graph on the same domain on
#   this machine is refused, naming the first (`cowork domain list` shows who holds which).
#
# --execute TASK: the robot carries out TASK (pourDrink, prepareCoffee, ...) with what was learned
#   in DIR (default config/learned, written by launch_scripts/teach.sh): the LTM
#   DIR/kitchen.learned.schema and a copy of the primitive database DIR/primitives (DIR itself
#   is never written). Steer it with `cowork say stop|repeat|human add(water)`. With --arms:
#   --execute pizza, DIR default config/learned-pizza (teach.sh --task pizza), its LTM
#   DIR/pizza.learned.schema and one database per arm in DIR/primitives.
# Otherwise (teaching, --teach TASK, default pourDrink): the supervisor allocates TASK from
#   STATE/kitchen.learned.schema when teaching has written one, else from
#   config/tasks/kitchen.schema; what it learns (LTM, STATE/primitives) is saved to STATE again
#   (--state DIR, default out; a fresh DIR starts from the bundled schema).
# --bridge: also `cowork bridge` (Foxglove WebSocket, ws://localhost:8765 or --bridge-port, and
#   the working-memory tree page on the next port, http://localhost:8766/):
#   open it in the Foxglove app with the layout config/foxglove-layout.json.
# --arms "A B": the scene has named arms (config/scenes/pizza.yaml: --arms "left right"); each arm
#   gets its own fded_distance, ds_controller and robot_manager in its ROS namespace (/A/...,
#   their `/A/<node>` parameter blocks), one human_observer in the first arm's namespace, and the
#   supervisor teaches or executes TASK (default pizza) of config/tasks/pizza.schema.
# Logs go to DIR/<node>.log (default: out/logs). Ctrl-C (or SIGTERM) stops every node cleanly.
# Nodes run from target/release; build first with `cargo build --release --bins`.
set -euo pipefail
self="$(cd "$(dirname "$0")" && pwd)/$(basename "$0")"  # to run again under a domain lease
cd "$(dirname "$0")/.."
all_args=("$@")
domain=${ROS_DOMAIN_ID:-0}

rate_args=(--rate 1)
duration_args=()
logs=out/logs
scene=config/scenes/kitchen.yaml
task=pourDrink
execute=
learned_dir=
state_dir=out
bridge=
bridge_port=8765
arms=()
while [[ $# -gt 0 ]]; do
  case "$1" in
    --rate) rate_args=(--rate "$2"); shift 2 ;;
    --max) rate_args=(--max); shift ;;
    --duration) duration_args=(--duration "$2"); shift 2 ;;
    --logs) logs="$2"; shift 2 ;;
    --scene) scene="$2"; shift 2 ;;
    --execute) task="$2"; execute=1; shift 2 ;;
    --teach) task="$2"; execute=; shift 2 ;;
    --learned) learned_dir="$2"; shift 2 ;;
    --state) state_dir="$2"; shift 2 ;;
    --bridge) bridge=1; shift ;;
    --bridge-port) bridge=1; bridge_port="$2"; shift 2 ;;
    --arms) read -r -a arms <<<"$2"; shift 2 ;;
    --domain) domain="$2"; shift 2 ;;
    -h|--help) sed -n '2,28p' "$0"; exit 0 ;;
    *) echo "graph.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done

if grep -q '^arms:' "$scene" && [[ ${#arms[@]} -eq 0 ]]; then
  echo "graph.sh: $scene has named arms: give them with --arms (e.g. --arms \"left right\")" >&2; exit 2
fi
learned_ltm=kitchen.learned.schema
if [[ ${#arms[@]} -gt 0 ]]; then
  [[ $task == pourDrink ]] && task=pizza
  learned_dir=${learned_dir:-config/learned-pizza}
  learned_ltm=pizza.learned.schema
fi
learned_dir=${learned_dir:-config/learned}

bin=target/release
for b in lwr_sim fded_distance human_observer attentional_supervisor ds_controller robot_manager cowork; do
  [[ -x $bin/$b ]] || { echo "graph.sh: $bin/$b missing; run: cargo build --release --bins" >&2; exit 1; }
done
# One graph per DDS domain on this machine: run again under a lease of the domain, held until
# the graph stops (the lease sets ROS_DOMAIN_ID).
if [[ -z ${COWORK_DOMAIN_HELD:-} ]]; then
  lease=(--domain "$domain")
  [[ $domain == auto ]] && lease=()
  exec "$bin/cowork" domain run "${lease[@]}" --what "launch_scripts/graph.sh" -- "$self" "${all_args[@]}"
fi
echo "graph on ROS_DOMAIN_ID=$ROS_DOMAIN_ID (talk to it with: ROS_DOMAIN_ID=$ROS_DOMAIN_ID cowork topic list)"
mkdir -p "$logs"
if [[ -n $execute ]]; then
  # What the robot runs: the learned LTM, and a fresh copy of the primitive database.
  ltm=$learned_dir/$learned_ltm
  databases=(lwr)
  [[ ${#arms[@]} -gt 0 ]] && databases=("${arms[@]/#/lwr_}")
  for d in "${databases[@]}"; do
    [[ -f $ltm && -f $learned_dir/primitives/$d.primitives.json ]] || {
      echo "graph.sh: nothing learned in $learned_dir ($ltm, primitives/$d.primitives.json; run launch_scripts/teach.sh${arms:+ --task pizza}, or give --learned DIR)" >&2; exit 1; }
  done
  database=out/execute/primitives
  save_ltm=out/execute/$learned_ltm
  rm -rf out/execute && mkdir -p out/execute && cp -r "$learned_dir/primitives" "$database"
else
  # A restart keeps what was taught: the learned LTM when there is one.
  database=$state_dir/primitives
  save_ltm=$state_dir/kitchen.learned.schema
  mkdir -p "$state_dir"
  ltm=config/tasks/kitchen.schema
  if [[ ${#arms[@]} -gt 0 ]]; then
    ltm=config/tasks/pizza.schema
    save_ltm=$state_dir/pizza.learned.schema
  fi
  [[ -f $save_ltm ]] && ltm=$save_ltm
fi

pids=()
names=()
start() { # name, command...
  local name=$1; shift
  "$@" >"$logs/$name.log" 2>&1 &
  pids+=($!)
  names+=("$name")
  echo "started $name (pid $!, log $logs/$name.log)"
}

stop_all() {
  trap - INT TERM EXIT
  for pid in "${pids[@]}"; do kill -INT "$pid" 2>/dev/null || true; done
  for i in "${!pids[@]}"; do
    # Give each node 5 s to leave the DDS domain cleanly, then force it.
    for _ in $(seq 50); do kill -0 "${pids[$i]}" 2>/dev/null || break; sleep 0.1; done
    if kill -0 "${pids[$i]}" 2>/dev/null; then
      echo "${names[$i]} did not stop; killing it" >&2
      kill -KILL "${pids[$i]}" 2>/dev/null || true
    fi
  done
  echo "graph stopped"
}
trap stop_all INT TERM EXIT

start lwr_sim $bin/lwr_sim --scene "$scene" "${rate_args[@]}" "${duration_args[@]}"
if [[ ${#arms[@]} -gt 0 ]]; then
  for arm in "${arms[@]}"; do
    ns=(--ros-args -r "__ns:=/$arm" --)
    start "fded_distance_$arm" $bin/fded_distance --params config/fded_distance.yaml --use-sim-time "${ns[@]}"
    start "ds_controller_$arm" $bin/ds_controller --params config/ds_controller.yaml --use-sim-time "${ns[@]}"
    start "robot_manager_$arm" $bin/robot_manager --params config/robot_manager.yaml --use-sim-time --database-dir "$database" "${ns[@]}"
  done
  # One observer: its /human/state distance is to the first arm.
  start human_observer $bin/human_observer --params config/human_observer.yaml --use-sim-time --ros-args -r "__ns:=/${arms[0]}" --
else
  # fDED distances (wgpu when a Vulkan adapter exists, else CPU; COWORK_FDED_BACKEND=cpu|gpu forces).
  start fded_distance $bin/fded_distance --params config/fded_distance.yaml --use-sim-time
  # The person near the robot: /human/state (far / interaction, alpha_h, stop), /human/gesture.
  start human_observer $bin/human_observer --params config/human_observer.yaml --use-sim-time
  # Reactive DS controller: /motion/command -> /lwr/joint_velocity_command (holds without fresh inputs).
  start ds_controller $bin/ds_controller --params config/ds_controller.yaml --use-sim-time
  # Robot manager: teaching (segments, primitive database), execution of the supervisor actions
  # through ds_controller and the gripper, /robot_stream and /object_stream.
  start robot_manager $bin/robot_manager --params config/robot_manager.yaml --use-sim-time --database-dir "$database"
fi
echo "supervisor: task $task from $ltm${execute:+ (executing)}"
start attentional_supervisor $bin/attentional_supervisor --ltm "$ltm" --task "$task" --use-sim-time --save-ltm "$save_ltm"
if [[ -n $bridge ]]; then
  # Live view: every topic over the Foxglove WebSocket protocol, stamped with the graph's /clock.
  # The working-memory tree page one port above the WebSocket.
  start cowork_bridge $bin/cowork bridge --port "$bridge_port" --use-sim-time --wm-page $((bridge_port + 1))
  layout=config/foxglove-layout.json
  [[ ${#arms[@]} -gt 1 ]] && layout=config/foxglove-layout-dual.json
  echo "Foxglove: open ws://localhost:$bridge_port (layout: $layout); working memory: http://localhost:$((bridge_port + 1))/"
fi

# Wait until any node exits (e.g. --duration reached) or a signal arrives.
wait -n "${pids[@]}" || true
