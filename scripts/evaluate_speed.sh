#!/usr/bin/env bash
# Speed over whole suites, with the accuracy reached, on this machine:
#  1. every scene of the 30-scene suite and the 36-scene viewpoint suite (seed 1) through
#     novelty_detect on one thread and on two (compute/threads), in NOVELTY_SPEED_ROUNDS
#     rounds (3), each run detecting its sweep twice (--repeat 2): per-stage medians and
#     worst cases of report.json's timings (each scene's median over the rounds) of the
#     second detection (a running node's, sweep after sweep) and of the first (a fresh
#     process's), scene success and point F1 (evaluate);
#  2. whole processes, interleaved: novelty_detect (its reference model built, and read back
#     from --reference-cache) against baseline_detect (octree change detector, 0.1 m voxels,
#     and Euclidean clusters) on the first 10 suite scenes, 3 rounds;
#  3. large clouds: a 300k-point office sweep (278 tilt lines) and, with the real data, the
#     organised 640x480 Kinect pair learn11 -> learn12: detection time and peak memory.
#
#   bash scripts/evaluate_speed.sh [--no-docs] [OUT_DIR=out/speed]
#
# Writes OUT_DIR/speed.md (and the runs under OUT_DIR), bench/results/speed.md and, unless
# --no-docs, the table of docs/evaluation.md between its speed-table markers. About 6
# minutes on 2 cores.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
DOCS_UPDATE=1
[ "${1:-}" = "--no-docs" ] && { DOCS_UPDATE=0; shift; }
OUT="${1:-$REPO/out/speed}"
BIN="$WS/devel/lib/novelty_detection"
build_tools simulate_scans novelty_detect baseline_detect evaluate
mkdir -p "$OUT"

simulate_once "$OUT/scenes/suite" --suite 30 --seed 1
simulate_once "$OUT/scenes/viewpoint" --suite 36 --suite-kind viewpoint --seed 1
simulate_once "$OUT/scenes/large" --seed 2 --layout office --lines 278

# 1. The suites, one thread and two: NOVELTY_SPEED_ROUNDS rounds (3 by default), each scene
# (detected twice in its process) on one thread then two in turn, so that the machine's drift
# falls on both alike; a scene's stage times are the medians of its rounds (report_rN.json),
# its outputs the same in each.
ROUNDS="${NOVELTY_SPEED_ROUNDS:-3}"
for threads in 1 2; do
  printf 'compute:\n  threads: %s\n' "$threads" > "$OUT/threads_$threads.yaml"
done
for round in $(seq 1 "$ROUNDS"); do
  for suite in suite viewpoint; do
    log "$suite suite on one thread and two, round $round of $ROUNDS"
    for scene in "$OUT/scenes/$suite"/scene_*; do
      for threads in 1 2; do
        dir="$OUT/threads_$threads/$suite/$(basename "$scene")"
        mkdir -p "$dir"
        [ "$round" = 1 ] && rm -f "$dir"/report_r*.json
        "$BIN/novelty_detect" --reference "$scene/ref.pcd" --current "$scene/cur.pcd" \
          --out "$dir" --config "$OUT/threads_$threads.yaml" --repeat 2 \
          > /dev/null 2> "$dir/stderr.log" ||
          log "$dir: novelty_detect failed: $(tail -n 1 "$dir/stderr.log")"
        [ -f "$dir/report.json" ] && cp "$dir/report.json" "$dir/report_r$round.json"
      done
    done
  done
done
for threads in 1 2; do
  for suite in suite viewpoint; do
    res="$OUT/threads_$threads/$suite"
    "$BIN/evaluate" --suite "$OUT/scenes/$suite" --results "$res" --json "$res.json" \
      > /dev/null 2> "$res.evaluate.log"
  done
done

# 2. Whole processes, interleaved (wall time of each process, start to exit).
printf 'resolution_m: 0.1\n' > "$OUT/octree.yaml"
: > "$OUT/processes.csv"
ms_since() { echo $((($(date +%s%N) - $1) / 1000000)); }
scenes=$(find "$OUT/scenes/suite" -maxdepth 1 -name 'scene_*' | sort | head -n 10)
for scene in $scenes; do  # the cache filled once, outside the timed rounds
  "$BIN/novelty_detect" --reference "$scene/ref.pcd" --current "$scene/cur.pcd" \
    --out "$OUT/process/warm" --reference-cache "$OUT/process/cache" > /dev/null 2>&1
done
log "whole processes: novelty_detect against baseline_detect, 10 scenes, 3 rounds"
for round in 1 2 3; do
  for scene in $scenes; do
    name=$(basename "$scene")
    t=$(date +%s%N)
    "$BIN/novelty_detect" --reference "$scene/ref.pcd" --current "$scene/cur.pcd" \
      --out "$OUT/process/cold" > /dev/null 2>&1
    cold=$(ms_since "$t")
    t=$(date +%s%N)
    "$BIN/novelty_detect" --reference "$scene/ref.pcd" --current "$scene/cur.pcd" \
      --out "$OUT/process/warm" --reference-cache "$OUT/process/cache" > /dev/null 2>&1
    warm=$(ms_since "$t")
    t=$(date +%s%N)
    "$BIN/baseline_detect" --reference "$scene/ref.pcd" --current "$scene/cur.pcd" \
      --out "$OUT/process/octree" --config "$OUT/octree.yaml" > /dev/null 2>&1
    octree=$(ms_since "$t")
    echo "$round,$name,$cold,$warm,$octree" >> "$OUT/processes.csv"
  done
done
for method in cold octree; do  # accuracy of what was timed, on the same 10 scenes
  mkdir -p "$OUT/process/scored_$method"
  for scene in $scenes; do
    dir="$OUT/process/scored_$method/$(basename "$scene")"
    mkdir -p "$dir"
    if [ "$method" = cold ]; then
      "$BIN/novelty_detect" --reference "$scene/ref.pcd" --current "$scene/cur.pcd" --out "$dir" \
        > /dev/null 2>&1 || true
    else
      "$BIN/baseline_detect" --reference "$scene/ref.pcd" --current "$scene/cur.pcd" \
        --out "$dir" --config "$OUT/octree.yaml" > /dev/null 2>&1 || true
    fi
  done
  "$BIN/evaluate" --suite "$OUT/scenes/suite" --results "$OUT/process/scored_$method" \
    --json "$OUT/process/scored_$method.json" > /dev/null 2>&1 || true
done

# 3. Large clouds: three runs each, the reference model read back from a cache.
: > "$OUT/large.csv"
large() {  # name reference current args...
  local name="$1" ref="$2" cur="$3"
  shift 3
  for run in 0 1 2 3; do  # run 0 fills the cache
    /usr/bin/time -f "%M" -o "$OUT/large_rss" "$BIN/novelty_detect" --reference "$ref" \
      --current "$cur" --out "$OUT/large/$name" --reference-cache "$OUT/large/cache" "$@" \
      > /dev/null 2>&1
    [ "$run" = 0 ] && continue
    echo "$name,$run,$(cat "$OUT/large_rss")" >> "$OUT/large.csv"
    cp "$OUT/large/$name/report.json" "$OUT/large/$name.report_$run.json"
  done
}
log "large clouds"
large office_300k "$OUT/scenes/large/ref.pcd" "$OUT/scenes/large/cur.pcd"
KINECT="${NOVELTY_REAL_DATA:-}/osd_tabletop_changes"
if [ -f "$KINECT/learn11.pcd" ]; then
  large kinect_307k "$KINECT/learn11.pcd" "$KINECT/learn12.pcd" --sensor-frame --up auto
else
  log "no real data ($KINECT): the Kinect row is left out"
fi

COMMIT="$(git -C "$REPO" rev-parse --short HEAD 2>/dev/null || echo unknown)"
MACHINE="$(nproc) cores ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'))"
LOAD="$(cut -d' ' -f1 /proc/loadavg)"
/usr/bin/python3 "$REPO/scripts/speed_tables.py" "$OUT" "$COMMIT" "$MACHINE" "$LOAD" \
  > "$OUT/speed.md"
mkdir -p "$REPO/bench/results"
cp "$OUT/speed.md" "$REPO/bench/results/speed.md"
if [ "$DOCS_UPDATE" = 1 ]; then
  docs_table speed-table "$OUT/speed.md"
fi
cat "$OUT/speed.md"
