#!/usr/bin/env bash
# cowork_motion against independent implementations (PyPI):
#   - GMR conditional mean vs gmr, 20 random mixtures, tolerance 1e-9;
#   - DTW distance vs dtaidistance, 200 random pairs, tolerance 1e-9;
#   - DMP reproduction error and speed vs movement_primitives (ours must be as good or better);
#   - LASA: GMR and C-GMR table with scikit-learn GaussianMixture + gmr side by side on the same K
#     (MOTION_LASA_MOTIONS motions, default 30; the data are exported to a temporary folder).
set -euo pipefail
cd "$(dirname "$0")/../.."
: "${VENV:=.venv-crosscheck}"
target="${CARGO_TARGET_DIR:-target}"
tool="$target/release/examples/motion_tool"
# run.sh's own build command (same packages, same features), so a no-op after it.
cargo build --release --locked --bins --examples 2>&1 | tail -n 1
py="$VENV/bin/python"
# One BLAS thread: fair against our single-threaded EM, and no oversubscription on small machines.
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
status=0
"$py" tests/crosscheck/check_motion.py gmr "$tool" "$work" 1e-9 || status=1
"$py" tests/crosscheck/check_motion.py dtw "$tool" "$work" 1e-9 || status=1
"$py" tests/crosscheck/check_motion.py dmp "$tool" "$work" || status=1

motions="${MOTION_LASA_MOTIONS:-30}"
subsample=20
"$py" tests/crosscheck/lasa_export.py "$work/lasa" >/dev/null
"$tool" lasa-k "$work/lasa" "$motions" 10 "$subsample" > "$work/ks.csv"
"$py" tests/crosscheck/check_motion.py lasa-sklearn "$work/lasa" "$work/ks.csv" "$work/skl" "$subsample" 2>/dev/null
"$tool" lasa "$work/lasa" "$motions" "$work/skl" 2>/dev/null | tee "$work/table.txt"
# C-GMR must bring every random start to the target.
if ! grep -q "C-GMR 100%" "$work/table.txt"; then
  echo "C-GMR did not reach the target from every random start"
  status=1
fi
exit $status
