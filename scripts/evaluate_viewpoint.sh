#!/usr/bin/env bash
# Viewpoint robustness: simulates the viewpoint suite (same pose / pose offset /
# localisation error, with removed objects), runs novelty_detect and the voxel-difference
# baseline (baseline_detect) on every scene, scores both per scene group and writes the
# Markdown table. This script is the single source of the viewpoint table of
# docs/evaluation.md (between its viewpoint-table markers), which it rewrites unless --no-docs.
#
#   bash scripts/evaluate_viewpoint.sh [--no-docs] [N=36] [OUT_DIR=out/viewpoint]
#
# Writes OUT_DIR/scenes (simulated; reused when size, seed and kind match and simulate_scans
# is older),
# OUT_DIR/{ours,baseline}/scene_XXX (outputs and logs), OUT_DIR/{ours,baseline}.json and .md
# (evaluate), OUT_DIR/viewpoint.md and, unless --no-docs, bench/results/viewpoint.md (the
# table). NOVELTY_SUITE_SEED (default 1) seeds the suite; NOVELTY_SUITE_SEEDS="1 2 3" runs one
# suite per seed and summarises them (below); NOVELTY_SKIP_BUILD=1 skips the build;
# NOVELTY_CONFIG=FILE.yaml is passed to novelty_detect as --config; NOVELTY_SUITE_NOISE_VAR
# sets the range noise variance [m^2] of the simulated scenes (default 0.001, the paper's).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
DOCS_UPDATE=1
case "${1:-}" in --no-docs | --no-readme) DOCS_UPDATE=0; shift ;; esac
N="${1:-36}"
OUT="${2:-$REPO/out/viewpoint}"
SEED="${NOVELTY_SUITE_SEED:-1}"
BIN="$WS/devel/lib/novelty_detection"
SUITE="$OUT/scenes"
case "$N" in '' | *[!0-9]*) log "N must be a positive integer, got '$N'"; exit 2 ;; esac

build_tools simulate_scans novelty_detect baseline_detect evaluate
for tool in simulate_scans novelty_detect baseline_detect evaluate; do
  [ -x "$BIN/$tool" ] || { log "missing $BIN/$tool: run scripts/build.sh first"; exit 1; }
done

# Several suite seeds (NOVELTY_SUITE_SEEDS="1 2 3 4 5"): the suite once per seed into
# OUT_DIR/seed_S (docs untouched), then OUT_DIR/seeds.md and seeds.json for novelty_detect
# and baseline_seeds.md / .json for the baseline: per scene group the mean over the seeds
# and the worst seed.
if [ -n "${NOVELTY_SUITE_SEEDS:-}" ]; then
  ours=() base=() rc=0
  for s in $NOVELTY_SUITE_SEEDS; do
    case "$s" in *[!0-9]*) log "NOVELTY_SUITE_SEEDS: '$s' is not a seed"; exit 2 ;; esac
    NOVELTY_SUITE_SEEDS= NOVELTY_SUITE_SEED="$s" NOVELTY_SKIP_BUILD=1 \
      bash "${BASH_SOURCE[0]}" --no-docs "$N" "$OUT/seed_$s" || rc=1
    ours+=(--seed-scores "$s=$OUT/seed_$s/ours.json")
    base+=(--seed-scores "$s=$OUT/seed_$s/baseline.json")
  done
  "$BIN/evaluate" "${ours[@]}" --markdown "$OUT/seeds.md" --json "$OUT/seeds.json"
  "$BIN/evaluate" "${base[@]}" --markdown "$OUT/baseline_seeds.md" \
    --json "$OUT/baseline_seeds.json" > /dev/null
  log "over seeds $NOVELTY_SUITE_SEEDS: $OUT/seeds.md (baseline: $OUT/baseline_seeds.md)"
  exit $rc
fi

start=$(date +%s)
suite_noise_args
# Reuse a suite simulated before with the same size, seed and kind by the same simulator.
if [ -f "$SUITE/suite.json" ] && [ "$SUITE/suite.json" -nt "$BIN/simulate_scans" ] && grep -Eq "\"size\": $N,?$" "$SUITE/suite.json" &&
  grep -Eq "\"suite_seed\": $SEED,?$" "$SUITE/suite.json" &&
  grep -Eq "\"kind\": \"viewpoint\",?$" "$SUITE/suite.json" && suite_noise_matches "$SUITE"; then
  log "reusing the simulated suite in $SUITE"
else
  rm -rf "$SUITE"
  log "simulating $N viewpoint scenes into $SUITE"
  mkdir -p "$OUT"
  "$BIN/simulate_scans" --out "$SUITE" --suite "$N" --suite-kind viewpoint --seed "$SEED" \
    --no-bag ${SUITE_NOISE_ARGS[@]+"${SUITE_NOISE_ARGS[@]}"} > "$OUT/simulate.log" 2>&1 || { cat "$OUT/simulate.log" >&2; exit 1; }
fi

rc=0
run_method() {  # name tool
  local name="$1" tool="$2" ok=0 failed=0 total_ms=0
  for scene in "$SUITE"/scene_*; do
    local s dir t0 ms
    s="$(basename "$scene")"
    dir="$OUT/$name/$s"
    mkdir -p "$dir"
    rm -f "$dir"/labels.txt "$dir"/disappeared_labels.txt "$dir"/newly_visible.txt
    t0=$(date +%s%N)
    local extra=()
    if [ "$tool" = novelty_detect ] && [ -n "${NOVELTY_CONFIG:-}" ]; then
      extra=(--config "$NOVELTY_CONFIG")
    fi
    if "$BIN/$tool" --reference "$scene/ref.pcd" --current "$scene/cur.pcd" --out "$dir" \
      "${extra[@]}" > "$dir/stdout.log" 2> "$dir/stderr.log"; then
      ms=$((($(date +%s%N) - t0) / 1000000))
      total_ms=$((total_ms + ms))
      ok=$((ok + 1))
    else
      failed=$((failed + 1))
      log "$name: $s: $tool failed: $(tail -n 1 "$dir/stderr.log")"
    fi
  done
  [ "$ok" -gt 0 ] && log "$name ($tool): $ok scenes, mean wall time $((total_ms / ok)) ms per scene"
  if [ "$failed" -gt 0 ]; then rc=1; fi
  "$BIN/evaluate" --suite "$SUITE" --results "$OUT/$name" --markdown "$OUT/$name.md" \
    --json "$OUT/$name.json" > /dev/null 2> "$OUT/$name.evaluate.log" || {
    cat "$OUT/$name.evaluate.log" >&2
    exit 1
  }
  grep -v "counted as failed" "$OUT/$name.evaluate.log" >&2 || true
}
run_method ours novelty_detect
run_method baseline baseline_detect

COMMIT="$(git -C "$REPO" rev-parse --short HEAD 2>/dev/null || echo unknown)"
/usr/bin/python3 - "$OUT" "$N" "$SEED" "$COMMIT" "$(($(date +%s) - start))" <<'PY'
import json, sys
out, n, seed, commit, seconds = sys.argv[1:6]
names = {"same_pose": "same pose", "pose_offset": "pose offset (5-30 cm, <= 10 deg)",
         "localisation_error": "localisation error (<= 3 cm, <= 1 deg)", "all": "all"}
methods = [("ours", "novelty_detect"),
           ("baseline", "octree change detector + Euclidean clusters")]
data = {m: {g["group"]: g for g in json.load(open(f"{out}/{m}.json"))["groups"]}
        for m, _ in methods}
def pct(a, b):
    return "-" if b == 0 else f"{100.0 * a / b:.0f} % ({a}/{b})"
rows = ["| scene group | method | scene success | mean point F1 (appearances) | "
        "disappearances found | newly visible points labelled novel |",
        "|---|---|---:|---:|---:|---:|"]
for group in data["ours"]:
    for m, label in methods:
        g = data[m].get(group)
        if g is None:
            continue
        f1 = f"{g['mean_f1']:.3f}" if g["appearance_scenes"] else "-"
        dis = pct(g["removal_scenes_found"], g["removal_scenes"])
        if g["removal_scenes_without_result"]:
            dis += f" [{g['removal_scenes_without_result']} without disappeared_labels.txt]"
        nv = (f"{100.0 * g['newly_visible_novel_fraction']:.1f} % "
              f"({g['newly_visible_novel']}/{g['newly_visible_points']})"
              if g["newly_visible_points"] else "-")
        rows.append(f"| {names.get(group, group)} ({g['scenes']} scenes) | {label} | "
                    f"{pct(g['successes'], g['scenes'])} | {f1} | {dis} | {nv} |")
text = ("\n".join(rows) + "\n\n"
        f"`bash scripts/evaluate_viewpoint.sh {n}` (suite seed {seed}, commit {commit}, "
        f"{seconds} s). Scene success and F1 as in the suite table; mean F1 is "
        "over scenes with appearances; a removal scene counts as found when every removed "
        "object has a disappearance segment with IoU >= 0.5 on its reference points.\n")
open(f"{out}/viewpoint.md", "w").write(text)
print(text)
PY
if [ "$DOCS_UPDATE" = 1 ]; then
  mkdir -p "$REPO/bench/results"
  cp "$OUT/viewpoint.md" "$REPO/bench/results/viewpoint.md"
  docs_table viewpoint-table "$OUT/viewpoint.md"
fi
if [ "$DOCS_UPDATE" = 1 ]; then
  log "table: $OUT/viewpoint.md (copied to bench/results/viewpoint.md)"
else
  log "table: $OUT/viewpoint.md"
fi
exit $rc
