#!/usr/bin/env bash
# Installs what is missing, builds, and runs the main job on the embedded default data.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
bash "$REPO/scripts/install_deps.sh"
bash "$REPO/scripts/build.sh"
BIN="$WS/devel/lib/novelty_detection"
OUT="${NOVELTY_DEMO_OUT:-$REPO/out/demo}"
mkdir -p "$OUT"
log "simulating a reference and a current sweep of a corridor with a new object"
"$BIN/simulate_scans" --out "$OUT/scene" --seed 1
log "outputs in $OUT/scene"
ls -l "$OUT/scene"
