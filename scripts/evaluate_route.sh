#!/usr/bin/env bash
# Patrol routes: N simulated route scenes (a reference of 8-20 sweeps with their viewpoints, a
# sequence of 5 current sweeps in which an object stays and a person walks through), each
# detected against the route map, against its nearest single sweep and by voxel differencing,
# the route map's results tracked over the sequence. Progress per scene on stderr; the last
# line on stdout is one JSON object (success_rate, mean_f1, confirmed_rate,
# transient_rejected_rate, the comparisons and the timings; docs/evaluation.md defines them).
#
#   bash scripts/evaluate_route.sh [N=30] [SEED=1]
#
# Writes out/route/seed_SEED.md (per-scene table and totals). NOVELTY_SKIP_BUILD=1 skips the
# build; NOVELTY_CONFIG=FILE.yaml sets the detector's parameters.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
N="${1:-30}"
SEED="${2:-1}"
case "$N" in '' | *[!0-9]* | 0) log "N must be a positive integer, got '$N'"; exit 2 ;; esac
case "$SEED" in '' | *[!0-9]*) log "SEED must be a non-negative integer, got '$SEED'"; exit 2 ;; esac
BIN="$WS/devel/lib/novelty_detection"
build_tools evaluate_route
[ -x "$BIN/evaluate_route" ] || { log "missing $BIN/evaluate_route: run scripts/build.sh first"; exit 1; }
OUT="$REPO/out/route"
mkdir -p "$OUT"
args=(--scenes "$N" --seed "$SEED" --markdown "$OUT/seed_$SEED.md")
[ -n "${NOVELTY_CONFIG:-}" ] && args+=(--params "$NOVELTY_CONFIG")
log "route suite: $N scenes, seed $SEED"
"$BIN/evaluate_route" "${args[@]}"
