#!/usr/bin/env bash
# Simulates the evaluation suite (once), runs novelty_detect on every scene and scores it.
#   scripts/run_suite.sh [N=30] [OUT_DIR=out/suite]
# Writes OUT_DIR/scenes (simulated, reused when present), OUT_DIR/results/scene_XXX (the
# detector's output and stderr.log), OUT_DIR/table.md, table.csv and scores.json.
# Build first (scripts/build.sh). The suite seed is NOVELTY_SUITE_SEED (default 1);
# NOVELTY_SUITE_SEEDS="1 2 3 4 5" runs one suite per seed and summarises them (below);
# NOVELTY_CONFIG=FILE.yaml is passed to novelty_detect as --config; NOVELTY_SUITE_NOISE_VAR
# sets the range noise variance [m^2] of the simulated scenes (default 0.001, the paper's).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
N="${1:-30}"
OUT="${2:-$REPO/out/suite}"
SEED="${NOVELTY_SUITE_SEED:-1}"
BIN="$WS/devel/lib/novelty_detection"
SUITE="$OUT/scenes"
RESULTS="$OUT/results"
CONFIG_ARGS=()
if [ -n "${NOVELTY_CONFIG:-}" ]; then
  [ -r "$NOVELTY_CONFIG" ] || { log "NOVELTY_CONFIG: cannot read '$NOVELTY_CONFIG'"; exit 2; }
  CONFIG_ARGS=(--config "$NOVELTY_CONFIG")
fi
case "$N" in '' | *[!0-9]*) log "N must be a positive integer, got '$N'"; exit 2 ;; esac
for tool in simulate_scans evaluate; do
  [ -x "$BIN/$tool" ] || { log "missing $BIN/$tool: run scripts/build.sh first"; exit 1; }
done
# Several suite seeds (NOVELTY_SUITE_SEEDS="1 2 3 4 5"): the suite once per seed into
# OUT_DIR/seed_S, then OUT_DIR/seeds.md and seeds.json: per scene group the mean over the
# seeds and the worst seed (evaluate --seed-scores).
if [ -n "${NOVELTY_SUITE_SEEDS:-}" ]; then
  args=() rc=0
  for s in $NOVELTY_SUITE_SEEDS; do
    case "$s" in *[!0-9]*) log "NOVELTY_SUITE_SEEDS: '$s' is not a seed"; exit 2 ;; esac
    NOVELTY_SUITE_SEEDS= NOVELTY_SUITE_SEED="$s" bash "${BASH_SOURCE[0]}" "$N" "$OUT/seed_$s" || rc=1
    args+=(--seed-scores "$s=$OUT/seed_$s/scores.json")
  done
  "$BIN/evaluate" "${args[@]}" --markdown "$OUT/seeds.md" --json "$OUT/seeds.json"
  log "over seeds $NOVELTY_SUITE_SEEDS: $OUT/seeds.md, $OUT/seeds.json"
  exit $rc
fi

# Reuse a suite simulated before with the same size and seed.
suite_noise_args
if [ -f "$SUITE/suite.json" ] && grep -Eq "\"size\": $N,?$" "$SUITE/suite.json" &&
  grep -Eq "\"suite_seed\": $SEED,?$" "$SUITE/suite.json" && suite_noise_matches "$SUITE"; then
  log "reusing the simulated suite in $SUITE"
else
  rm -rf "$SUITE"
  log "simulating $N scenes into $SUITE"
  "$BIN/simulate_scans" --out "$SUITE" --suite "$N" --seed "$SEED" --no-bag \
    ${SUITE_NOISE_ARGS[@]+"${SUITE_NOISE_ARGS[@]}"}
fi

rc=0
if [ ! -x "$BIN/novelty_detect" ]; then
  log "novelty_detect is missing ($BIN/novelty_detect): build the detection CLI first;" \
    "every scene is scored as failed"
  rc=1
else
  ok=0
  failed=0
  total_ms=0
  for scene in "$SUITE"/scene_*; do
    name="$(basename "$scene")"
    mkdir -p "$RESULTS/$name"
    rm -f "$RESULTS/$name/labels.txt"
    t0=$(date +%s%N)
    if "$BIN/novelty_detect" --reference "$scene/ref.pcd" --current "$scene/cur.pcd" \
      --out "$RESULTS/$name" "${CONFIG_ARGS[@]}" \
      > "$RESULTS/$name/stdout.log" 2> "$RESULTS/$name/stderr.log"; then
      ms=$((($(date +%s%N) - t0) / 1000000))
      total_ms=$((total_ms + ms))
      ok=$((ok + 1))
      log "$name: done in $ms ms"
    else
      failed=$((failed + 1))
      log "$name: novelty_detect failed: $(tail -n 1 "$RESULTS/$name/stderr.log")"
    fi
  done
  if [ "$ok" -gt 0 ]; then
    log "novelty_detect ran on $ok scenes, mean wall time $((total_ms / ok)) ms per scene" \
      "(process start and file I/O included)"
  fi
  if [ "$failed" -gt 0 ]; then
    log "novelty_detect failed on $failed of $((ok + failed)) scenes (see results/*/stderr.log)"
    rc=1
  fi
fi

mkdir -p "$RESULTS"
"$BIN/evaluate" --suite "$SUITE" --results "$RESULTS" --markdown "$OUT/table.md" \
  --csv "$OUT/table.csv" --json "$OUT/scores.json"
log "tables: $OUT/table.md, $OUT/table.csv, $OUT/scores.json"
exit $rc
