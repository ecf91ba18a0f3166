#!/usr/bin/env bash
# Runs the simulated suite and the viewpoint suite with two builds and compares their outputs
# file by file: labels, newly visible flags, disappearances, superquadrics and report.json
# (wall times and the alignment's own time left out). For changes that must not change
# behaviour (a restructure, a speed-up that claims identical results).
#   scripts/compare_builds.sh WS_A WS_B [OUT_DIR=out/compare] [N_SUITE=30] [N_VIEWPOINT=36]
# WS_A and WS_B are catkin workspaces built by scripts/build.sh (e.g. NOVELTY_WS=DIR of a
# clone checked out at another commit). Exits 1 when any output differs.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
[ $# -ge 2 ] || { log "usage: scripts/compare_builds.sh WS_A WS_B [OUT_DIR] [N_SUITE] [N_VIEWPOINT]"; exit 2; }
A="$(cd "$1" && pwd)"
B="$(cd "$2" && pwd)"
OUT="${3:-$REPO/out/compare}"
N_SUITE="${4:-30}"
N_VIEW="${5:-36}"
for ws in "$A" "$B"; do
  [ -x "$ws/devel/lib/novelty_detection/novelty_detect" ] || {
    log "$ws has no build of novelty_detect (scripts/build.sh with NOVELTY_WS=$ws)"; exit 2; }
done
mkdir -p "$OUT"
for side in a b; do
  mkdir -p "$OUT/$side"
  ws=$A; [ $side = b ] && ws=$B
  log "build $side ($ws): simulated suite ($N_SUITE scenes)"
  NOVELTY_WS="$ws" bash "$REPO/scripts/run_suite.sh" "$N_SUITE" "$OUT/$side/suite" > "$OUT/$side/suite.log" 2>&1
  log "build $side: viewpoint suite ($N_VIEW scenes)"
  NOVELTY_WS="$ws" NOVELTY_SKIP_BUILD=1 bash "$REPO/scripts/evaluate_viewpoint.sh" --no-docs "$N_VIEW" "$OUT/$side/viewpoint" \
    > "$OUT/$side/viewpoint.log" 2>&1
done
/usr/bin/python3 - "$OUT/a" "$OUT/b" <<'PY'
import json, pathlib, sys
a_root, b_root = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
TEXT = ["labels.txt", "newly_visible.txt", "disappeared_labels.txt"]
JSON = ["superquadrics.json", "disappeared_superquadrics.json", "report.json"]
def strip(x):
    """report.json without what depends on the machine's speed."""
    if isinstance(x, dict):
        return {k: strip(v) for k, v in x.items() if k not in ("timings_ms", "ms")}
    if isinstance(x, list):
        return [strip(v) for v in x]
    return x
scenes = differing = files = 0
for group in ["suite/results", "viewpoint/ours"]:
    for da in sorted((a_root / group).glob("scene_*")):
        db = b_root / group / da.name
        scenes += 1
        diffs = []
        for name in TEXT + JSON:
            fa, fb = da / name, db / name
            if not fa.exists() and not fb.exists():
                continue
            files += 1
            if not fa.exists() or not fb.exists():
                diffs.append(name + " (missing on one side)")
            elif name in TEXT:
                if fa.read_text() != fb.read_text():
                    diffs.append(name)
            elif strip(json.loads(fa.read_text())) != strip(json.loads(fb.read_text())):
                diffs.append(name)
        if diffs:
            differing += 1
            print(f"{group}/{da.name}: differs in {', '.join(diffs)}")
print(f"compared {files} files of {scenes} scenes: {differing} scenes differ")
sys.exit(1 if differing else 0)
PY
