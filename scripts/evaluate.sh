#!/usr/bin/env bash
# Builds the package, reproduces Table I (table1) and measures scaling (scaling), writes
# bench/results/{table1,scaling}.{md,csv} and scaling.png, and prints them with the machine
# and settings they were measured on.
#
#   bash scripts/evaluate.sh           # full run: 30 scenes, 3k..1M points, maps 100k..5M
#   bash scripts/evaluate.sh --quick   # smoke run: 3 scenes, small sizes (results in a temp dir)
#
# Real pairs are read from $NOVELTY_REAL_DATA/osd_tabletop_changes when that directory
# exists (skipped otherwise).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
QUICK=0
[ "${1:-}" = "--quick" ] && QUICK=1

bash "$REPO/scripts/build.sh" table1 scaling
BIN="$WS/devel/lib/novelty_detection"
if [ "$QUICK" = 1 ]; then
  OUT="$(mktemp -d)"
  TABLE_ARGS=(--scenes 3)
  SCALING_ARGS=(--sizes 3000,30000 --map-sizes 30000,100000 --repeat 1)
else
  OUT="$REPO/bench/results"
  TABLE_ARGS=(--scenes 30 --coarse)
  SCALING_ARGS=(--repeat 3)
fi
mkdir -p "$OUT"
REAL="${NOVELTY_REAL_DATA:-}/osd_tabletop_changes"
if [ -n "${NOVELTY_REAL_DATA:-}" ] && [ "$QUICK" = 0 ]; then
  # Novel object ids of the AFTER cloud (label / 10), see the data's SOURCE.md.
  TABLE_ARGS+=(--real "$REAL/test14.pcd" "$REAL/test15.pcd" 2
               --real "$REAL/learn11.pcd" "$REAL/learn12.pcd" 3
               --real "$REAL/test31.pcd" "$REAL/test32.pcd" 3,4,5)
fi

{
  echo "Machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'),"\
       "$(awk '/MemTotal/ {printf "%.1f GB RAM", $2/1048576}' /proc/meminfo), load $(cut -d' ' -f1-3 /proc/loadavg)"
  echo "Build: ${NOVELTY_BUILD_TYPE:-Release}, compute/threads default (0: $(nproc) threads for the superquadric fits); commit $(git -C "$REPO" rev-parse --short HEAD)"
  echo "Parameters: config/default.yaml defaults (finest cut: multiscale/n_max 1, gmm/max_fit_points unlimited)"
  echo "Date: $(date -u '+%Y-%m-%d %H:%M UTC')"
} > "$OUT/machine.txt"

log "Table I reproduction: table1 ${TABLE_ARGS[*]}"
"$BIN/table1" "${TABLE_ARGS[@]}" --markdown "$OUT/table1.md.tmp" --csv "$OUT/table1.csv"
{ cat "$OUT/machine.txt"; echo; cat "$OUT/table1.md.tmp"; } > "$OUT/table1.md"
rm -f "$OUT/table1.md.tmp"

log "scaling: scaling ${SCALING_ARGS[*]}"
"$BIN/scaling" "${SCALING_ARGS[@]}" --markdown "$OUT/scaling.md.tmp" --csv "$OUT/scaling.csv"
{ cat "$OUT/machine.txt"; echo; cat "$OUT/scaling.md.tmp"; } > "$OUT/scaling.md"
rm -f "$OUT/scaling.md.tmp" "$OUT/machine.txt"
if /usr/bin/python3 -c "import matplotlib" 2>/dev/null; then
  /usr/bin/python3 "$REPO/scripts/plot_scaling.py" "$OUT/scaling.csv" "$OUT/scaling.png"
else
  log "python3-matplotlib missing: no scaling.png"
fi

echo; cat "$OUT/table1.md"; echo; cat "$OUT/scaling.md"
log "results in $OUT"
