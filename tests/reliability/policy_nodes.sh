#!/usr/bin/env bash
# Does config/security/policy.xml grant each node what it opens? Starts each of the six nodes
# alone for 4 s, secured (Enforce) with an enclave signed from the policy, and prints the
# topics the access-control plugin refused it ("ok" when none). Needs the nodes and cowork
# built with security:
#   cargo build --release --bins -p lwr_sim -p fded_distance -p human_observer -p ds_controller \
#       -p robot_manager -p attentional_supervisor -p cowork --features cowork_ros/security
#   bash tests/reliability/policy_nodes.sh
# The whole graph with these enclaves: POLICY=1 bash tests/reliability/secured_graph.sh.
set -euo pipefail
cd "$(dirname "$0")/../.."
: "${ROS_DOMAIN_ID:=219}"
out=$(mktemp -d /tmp/cowork-policy-XXXX)
ks=$out/keystore
target/release/cowork keystore create "$ks" >/dev/null 2>&1
target/release/cowork keystore enclave "$ks" lwr_sim fded_distance human_observer ds_controller \
  robot_manager attentional_supervisor --policy "${POLICY_FILE:-config/security/policy.xml}" >/dev/null 2>&1
declare -A args=(
  [lwr_sim]="--scene config/scenes/kitchen.yaml --params config/lwr_sim.yaml --rate 1"
  [fded_distance]="--params config/fded_distance.yaml --use-sim-time"
  [human_observer]="--params config/human_observer.yaml --use-sim-time"
  [ds_controller]="--params config/ds_controller.yaml --use-sim-time"
  [robot_manager]="--params config/robot_manager.yaml --use-sim-time"
  [attentional_supervisor]="--params config/attentional_supervisor.yaml --use-sim-time --ltm config/tasks/kitchen.schema --task pourDrink"
)
failed=0
for n in lwr_sim fded_distance human_observer ds_controller robot_manager attentional_supervisor; do
  rc=0
  # shellcheck disable=SC2086
  ROS_DOMAIN_ID=$ROS_DOMAIN_ID ROS_SECURITY_ENABLE=true ROS_SECURITY_STRATEGY=Enforce ROS_SECURITY_KEYSTORE=$ks \
    RUST_BACKTRACE=0 timeout -s INT 4 "target/release/$n" ${args[$n]} > "$out/$n.log" 2>&1 || rc=$?
  refused=$(sed 's/\x1b\[[0-9;]*m//g' "$out/$n.log" | grep -o "Not allowed to create the topic [^ ]*" | sort -u | sed 's/.* //' | tr '\n' ' ' || true)
  # 124: still running when stopped after 4 s, as it should be.
  if [[ $rc -eq 124 && -z "$refused" ]]; then
    echo "$n: ok"
  else
    echo "$n: exit $rc, refused: ${refused:-none} (log $out/$n.log)"
    failed=1
  fi
done
exit $failed
