#!/usr/bin/env bash
# The experiment report in a browser: a short stacking-hri trial in the graph writes its report
# (`cowork experiment --report`), headless Chromium (Debian `chromium`, installed by
# tests/install-system-deps.sh) opens index.html, dumps the DOM after load and takes a
# screenshot; check_report.py checks every plot loaded, the summary table fits a 1400 px window,
# every legend entry has data in the plot's CSV, and the screenshot is not blank and shows the
# plots. The screenshot is kept at $REPORT_OUT/report.png (default out/crosscheck-report).
set -euo pipefail
cd "$(dirname "$0")/../.."
: "${VENV:=.venv-crosscheck}"
target="${CARGO_TARGET_DIR:-target}"
out="${REPORT_OUT:-out/crosscheck-report}"

browser=""
for b in chromium chromium-browser google-chrome; do
  if command -v "$b" >/dev/null 2>&1; then browser=$(command -v "$b"); break; fi
done
if [[ -z "$browser" ]]; then
  echo "check_report: no chromium; installing it with tests/install-system-deps.sh"
  bash tests/install-system-deps.sh || true
  command -v chromium >/dev/null 2>&1 && browser=$(command -v chromium)
fi
if [[ -z "$browser" ]]; then
  if [[ -n "${CI:-}" ]]; then
    echo "check_report: FAILED: chromium cannot be installed (CI is set)"
    exit 1
  fi
  echo "check_report: SKIPPED: no chromium and it could not be installed (run tests/install-system-deps.sh as root)"
  exit 0
fi

# run.sh's own build command (same packages, same features), so a no-op after it.
cargo build --release --locked --bins --examples 2>&1 | tail -n 1
rm -rf "$out"
mkdir -p "$out"
# 8 simulated seconds in real time (--max would outrun the controller, which then holds): the
# person walks in, fDED, the observer and the controller run; the trial ends on its time limit
# (that is expected here).
"$target/release/cowork" experiment stacking-hri --trials 1 --seed 2 --rate 1 --time-limit 8 \
  --bin-dir "$target/release" --logs "$out/logs" --json "$out/run.json" --report "$out/report" \
  > "$out/experiment.txt" 2>&1 || { cat "$out/experiment.txt"; echo "check_report: the experiment failed to run"; exit 1; }
tail -n 3 "$out/experiment.txt"

page="file://$(cd "$out/report" && pwd)/index.html"
# A private profile: no first-run state, nothing shared with a desktop session.
profile=$(mktemp -d)
trap 'rm -rf "$profile"' EXIT
flags=(--headless --no-sandbox --disable-gpu --hide-scrollbars --user-data-dir="$profile"
       --no-first-run --virtual-time-budget=5000)
# The DOM at a 1400 px wide window: the page's load script measures whether the summary table
# fits (data-summary-fits) at that width.
timeout 120 "$browser" "${flags[@]}" --window-size=1400,2600 --dump-dom "$page" > "$out/dom.html" 2> "$out/chromium-dom.log"
timeout 120 "$browser" "${flags[@]}" --window-size=1400,2600 --screenshot="$out/report.png" "$page" \
  > "$out/chromium-shot.log" 2>&1
[[ -s "$out/report.png" ]] || { tail -n 5 "$out/chromium-shot.log"; echo "check_report: no screenshot"; exit 1; }
python3 tests/crosscheck/check_report.py "$out/report" "$out/report.png" "$out/dom.html"
echo "check_report: screenshot $out/report.png"
