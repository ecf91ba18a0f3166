#!/usr/bin/env bash
# Renders an rviz screenshot of the detector's output headless under Xvfb. Needs the view
# packages: scripts/install_deps.sh --with-rviz (run by this script).
#   scripts/screenshot.sh [OUT.png]           the demo scene (run scripts/demo.sh first)
#   scripts/screenshot.sh --kinect [OUT.png]  a real Kinect pair of the real-scan data set
#                                             (osd_tabletop_changes learn11 -> learn12: a new box)
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
MODE=demo
if [ "${1:-}" = "--kinect" ]; then MODE=kinect; shift; fi
bash "$REPO/scripts/install_deps.sh" --with-rviz
OUT_PNG="$(realpath -m "${1:-$REPO/out/screenshot_$MODE.png}")"
mkdir -p "$(dirname "$OUT_PNG")"
if [ "$MODE" = demo ]; then
  SCENE="${NOVELTY_DEMO_OUT:-$REPO/out/demo}/scene"
  [ -f "$SCENE/scans.bag" ] || { log "no $SCENE/scans.bag: run scripts/demo.sh first"; exit 1; }
  # rviz needs a few seconds to start; the bag plays after 8 s and lasts ~2 s; the last
  # (current) sweep and its results stay on screen.
  LAUNCH_ARGS=(replay.launch bag:="$SCENE/scans.bag" reference_file:="$SCENE/ref.pcd"
    sensor_frame:=laser rviz:=true delay:=8)
else
  PAIR="$NOVELTY_REAL_DATA/osd_tabletop_changes"
  [ -f "$PAIR/learn12.pcd" ] || { log "no $PAIR/learn12.pcd: set NOVELTY_REAL_DATA"; exit 1; }
  # The camera looks down at the table: the view frame turns the table's normal, as
  # `novelty_detect --sensor-frame --up auto` measures it on this pair (report.json `up`:
  # 0.009 -0.740 -0.672), to +z.
  LAUNCH_ARGS=(cloud_pair.launch reference_file:="$PAIR/learn11.pcd"
    current:="$PAIR/learn12.pcd" frame:=camera optical:=true rviz:=true
    view_pose:="0 0 0 -1.5628 -0.0088 -2.3080" config:="$REPO/config/depth_camera.yaml")
fi
source_devel
DISPLAY_NUM=":${NOVELTY_XVFB_DISPLAY:-97}"
Xvfb "$DISPLAY_NUM" -screen 0 1280x800x24 +extension GLX +render -noreset >/dev/null 2>&1 &
XVFB=$!
trap 'kill -INT ${LAUNCH:-} 2>/dev/null || true; sleep 2; kill $XVFB 2>/dev/null || true' EXIT
export DISPLAY="$DISPLAY_NUM" LIBGL_ALWAYS_SOFTWARE=1
sleep 2
LOG="$WS/screenshot_launch.log"
roslaunch novelty_detection "${LAUNCH_ARGS[@]}" >"$LOG" 2>&1 &
LAUNCH=$!
sleep "${NOVELTY_SCREENSHOT_WAIT:-25}"
import -window root "$OUT_PNG"
# Keep the 3D view only (rviz's panel is on the left) with a palette, to keep the PNG small;
# NOVELTY_SCREENSHOT_FULL=1 keeps the whole window.
if [ "${NOVELTY_SCREENSHOT_FULL:-0}" != 1 ]; then
  /usr/bin/convert "$OUT_PNG" -crop 900x708+364+62 +repage -colors 192 "$OUT_PNG"
fi
log "screenshot saved to $OUT_PNG"
echo "$OUT_PNG"
