#!/usr/bin/env bash
# Installs what is missing, builds, and runs the main job on the embedded default data.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
bash "$REPO/scripts/install_deps.sh"
bash "$REPO/scripts/build.sh"
BIN="$WS/devel/lib/novelty_detection"
OUT="${NOVELTY_DEMO_OUT:-$REPO/out/demo}"
mkdir -p "$OUT"
log "simulating a reference and a current sweep of a corridor with two new objects"
"$BIN/simulate_scans" --out "$OUT/scene" --seed 1 --novelties 2
log "outputs in $OUT/scene:"
log "  ref.pcd, cur.pcd   the two sweeps (binary PCD, world frame, VIEWPOINT = sensor pose)"
log "  gt_labels.txt      one label per point of cur.pcd (0 static, k > 0 changed object k)"
log "  scene.json         the changed objects with their true superquadrics, sensor poses"
log "  scans.bag          /scan (LaserScan lines), /tf (tilt joint), /sweep (PointCloud2)"
ls -l "$OUT/scene"
