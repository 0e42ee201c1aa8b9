#!/usr/bin/env bash
# Regenerates the sample bags listed in bags/bags.txt with `cowork bag synth`.
#   bags/regenerate.sh            (uses target/release/cowork; COWORK=path to use another binary)
set -euo pipefail
cd "$(dirname "$0")/.."
cowork=${COWORK:-target/release/cowork}
grep -v '^\s*#' bags/bags.txt | while read -r file scenario seed duration flags; do
  [[ -z "$file" ]] && continue
  # shellcheck disable=SC2086 # flags are separate words
  "$cowork" bag synth "$scenario" -o "bags/$file" --seed "$seed" --duration "$duration" $flags
done
