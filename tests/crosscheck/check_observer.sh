#!/usr/bin/env bash
# cowork_observer's constant-velocity hand Kalman filter against filterpy (PyPI): the same
# noisy right-hand track of a synthetic person (30 Hz depth tracker with lost frames and stamp
# jitter; 120 Hz Xsens), the same F, Q (Q_continuous_white_noise), H, R and start, every
# filtered position and velocity equal to 1e-9; and the filter must beat the raw measurement
# against the noise-free truth (RMSE table printed).
set -euo pipefail
cd "$(dirname "$0")/../.."
: "${VENV:=.venv-crosscheck}"
target="${CARGO_TARGET_DIR:-target}"
tool="$target/release/examples/kalman_track"
# run.sh's own build command (same packages, same features), so a no-op after it.
cargo build --release --locked --bins --examples 2>&1 | tail -n 1
py="$VENV/bin/python"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
status=0
# seed, sensor, process noise (m^2/s^3), measurement noise (m), initial velocity std (m/s)
for args in "3 depth 1.0 0.015 1.0" "4 depth 4.0 0.02 0.5" "3 xsens 1.0 0.004 1.0"; do
  read -r seed sensor q r v0 <<<"$args"
  csv="$work/track_${seed}_${sensor}_${q}.csv"
  "$tool" "$seed" "$sensor" "$q" "$r" "$v0" "$csv"
  "$py" tests/crosscheck/check_observer.py "$csv" "$q" "$r" "$v0" 1e-9 || status=1
done
exit $status
