#!/usr/bin/env bash
# cowork_robot FK and Jacobians against kinpy (PyPI) on the same URDFs, over 1000 random
# configurations each: the bundled LWR IV+ and a hand-written 7-DoF arm with skewed axes, rpy
# offsets, a continuous joint, fixed joints mid-chain and a side branch. Tolerance 1e-9.
set -euo pipefail
cd "$(dirname "$0")/../.."
: "${VENV:=.venv-crosscheck}"
target="${CARGO_TARGET_DIR:-target}"
dump="$target/release/examples/fk_dump"
# run.sh's own build command (same packages, same features), so a no-op after it.
cargo build --release --locked --bins --examples 2>&1 | tail -n 1
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
status=0
for urdf in config/robot/lwr4plus.urdf nodes/lib/robot/tests/data/other_7dof/urdf/other_7dof.urdf; do
  name=$(basename "$urdf" .urdf)
  "$dump" --urdf "$urdf" --count "${KINEMATICS_COUNT:-1000}" --seed "${KINEMATICS_SEED:-20241122}" --out "$out/$name.json"
  "$VENV/bin/python" tests/crosscheck/check_kinematics.py "$urdf" "$out/$name.json" "${KINEMATICS_TOL:-1e-9}" || status=1
done
exit $status
