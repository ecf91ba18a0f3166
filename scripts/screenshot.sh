#!/usr/bin/env bash
# Renders an rviz screenshot of the detector's output on the demo scene, headless under
# Xvfb. Needs the view packages: scripts/install_deps.sh --with-rviz. Run scripts/demo.sh
# first (it builds and simulates the scene). Usage: scripts/screenshot.sh [OUT.png]
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
bash "$REPO/scripts/install_deps.sh" --with-rviz
OUT_PNG="$(realpath -m "${1:-$REPO/out/screenshot.png}")"
SCENE="${NOVELTY_DEMO_OUT:-$REPO/out/demo}/scene"
[ -f "$SCENE/scans.bag" ] || { log "no $SCENE/scans.bag: run scripts/demo.sh first"; exit 1; }
mkdir -p "$(dirname "$OUT_PNG")"
source_devel
DISPLAY_NUM=":${NOVELTY_XVFB_DISPLAY:-97}"
Xvfb "$DISPLAY_NUM" -screen 0 1280x800x24 +extension GLX +render -noreset >/dev/null 2>&1 &
XVFB=$!
trap 'kill -INT ${LAUNCH:-} 2>/dev/null || true; sleep 2; kill $XVFB 2>/dev/null || true' EXIT
export DISPLAY="$DISPLAY_NUM" LIBGL_ALWAYS_SOFTWARE=1
sleep 2
LOG="$WS/screenshot_launch.log"
roslaunch novelty_detection replay.launch bag:="$SCENE/scans.bag" \
  reference_file:="$SCENE/ref.pcd" rviz:=true delay:=8 >"$LOG" 2>&1 &
LAUNCH=$!
# rviz needs a few seconds to start; the bag plays after 8 s and lasts ~2 s; the last
# (current) sweep and its results stay on screen.
sleep "${NOVELTY_SCREENSHOT_WAIT:-25}"
import -window root "$OUT_PNG"
# Keep the 3D view only (rviz's panel is on the left) with a palette, to keep the PNG small;
# NOVELTY_SCREENSHOT_FULL=1 keeps the whole window.
if [ "${NOVELTY_SCREENSHOT_FULL:-0}" != 1 ]; then
  /usr/bin/convert "$OUT_PNG" -crop 900x708+364+62 +repage -colors 192 "$OUT_PNG"
fi
log "screenshot saved to $OUT_PNG"
echo "$OUT_PNG"
