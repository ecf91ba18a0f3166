#!/usr/bin/env bash
# Installs what is missing, builds, simulates a scene pair (reference and current sweep of
# a corridor with a new object) and replays its rosbag through the detector nodelet, which
# prints each detected novelty with its superquadrics.
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

# The bag holds the reference sweep, then the current one (/sweep in map, /scan, /tf).
# The detector compares both with ref.pcd: the first should show nothing, the second the
# inserted objects. The laser's pose on /tf (sensor_frame) is each sweep's viewpoint: the
# free-space reasoning and the fits bounded by what the sweep saw need it.
log "replaying $OUT/scene/scans.bag through the detector nodelet (reference: ref.pcd)"
source_devel
roslaunch novelty_detection replay.launch bag:="$OUT/scene/scans.bag" \
  reference_file:="$OUT/scene/ref.pcd" sensor_frame:=laser print:=true print_count:=2 2>&1 |
  grep -E --line-buffered "^(sweep|  novelty|    superquadric|print_novelties)|ERROR|FATAL" || true
log "ground truth: $OUT/scene/scene.json (labels: gt_labels.txt)"
