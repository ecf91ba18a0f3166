#!/usr/bin/env bash
# Builds the package in an out-of-tree catkin workspace (.ws/, git-ignored).
# Extra arguments go to catkin_make (e.g. a target name).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
mkdir -p "$WS/src" "$WS/devel/lib/python3/dist-packages"
ln -sfn "$REPO" "$WS/src/novelty_detection"
cd "$WS"
log "building in $WS"
catkin_make -j"${NOVELTY_JOBS:-2}" -DPYTHON_EXECUTABLE=/usr/bin/python3 \
  -DPython3_EXECUTABLE=/usr/bin/python3 -DCMAKE_BUILD_TYPE="${NOVELTY_BUILD_TYPE:-Release}" \
  -DNOVELTY_SANITIZE="${NOVELTY_SANITIZE:-OFF}" "$@" > "$WS/build.log" 2>&1 || {
  tail -60 "$WS/build.log" >&2
  log "build failed (full log: $WS/build.log)"
  exit 1
}
log "build ok"
