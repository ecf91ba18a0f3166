#!/usr/bin/env bash
# Where detection time goes inside the stages, from perf's samples: novelty_detect on one
# thread over (1) the first 20 scenes of the 30-scene suite (30k points each), (2) the 300k
# point office sweep (278 tilt lines) and (3) with the real data, the organised 640x480
# Kinect pair learn11 -> learn12; each run reads its reference model back from a cache, so
# that detection is what is sampled. Self time of the novelty_detect processes, grouped into
# neighbour searches, k-d tree builds, the kernel (page faults) and the next five functions,
# as shares of all their samples.
#
#   bash scripts/profile.sh [--no-docs] [OUT_DIR=out/profile]
#
# Needs perf (linux-perf) and the scenes of scripts/evaluate_speed.sh (simulated when
# missing). Writes OUT_DIR/profile.md and, unless --no-docs, the table of
# docs/evaluation.md between its profile-table markers. About 3 minutes on 2 cores.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
DOCS_UPDATE=1
[ "${1:-}" = "--no-docs" ] && { DOCS_UPDATE=0; shift; }
OUT="${1:-$REPO/out/profile}"
BIN="$WS/devel/lib/novelty_detection"
SPEED="$REPO/out/speed/scenes"
command -v perf > /dev/null || { log "perf is not installed (apt install linux-perf)"; exit 1; }
build_tools simulate_scans novelty_detect
mkdir -p "$OUT"
printf 'compute:\n  threads: 1\n' > "$OUT/one_thread.yaml"
# The scenes of scripts/evaluate_speed.sh.
simulate_once "$SPEED/suite" --suite 30 --seed 1
simulate_once "$SPEED/large" --seed 2 --layout office --lines 278

# run_case NAME LIST: one run per line of LIST ("reference current [arguments]") into a
# script, run once to fill the caches and once under perf; the report in OUT_DIR/NAME.txt.
run_case() {
  local name="$1" list="$2" runner="$OUT/$1.sh"
  {
    echo "set -e"
    while read -r ref cur extra; do
      echo "'$BIN/novelty_detect' --reference '$ref' --current '$cur' --out '$OUT/out_$name'" \
        "--config '$OUT/one_thread.yaml' --reference-cache '$OUT/cache_$name' $extra" \
        "> /dev/null 2>&1"
    done < "$list"
  } > "$runner"
  bash "$runner"  # fills the caches
  log "profiling $name"
  perf record -F 999 -o "$OUT/$name.data" -- bash "$runner" > /dev/null 2> "$OUT/$name.perf.log"
  perf report -i "$OUT/$name.data" --comm novelty_detect --no-children --sort dso,symbol \
    --stdio -q 2> /dev/null > "$OUT/$name.txt"
}
: > "$OUT/suite.list"
for scene in $(find "$SPEED/suite" -maxdepth 1 -name 'scene_*' | sort | head -n 20); do
  echo "$scene/ref.pcd $scene/cur.pcd" >> "$OUT/suite.list"
done
run_case suite "$OUT/suite.list"
for k in 1 2 3; do echo "$SPEED/large/ref.pcd $SPEED/large/cur.pcd"; done > "$OUT/office.list"
run_case office "$OUT/office.list"
KINECT="${NOVELTY_REAL_DATA:-}/osd_tabletop_changes"
cases="suite office"
if [ -f "$KINECT/learn11.pcd" ]; then
  for k in 1 2 3; do
    echo "$KINECT/learn11.pcd $KINECT/learn12.pcd --sensor-frame --up auto"
  done > "$OUT/kinect.list"
  run_case kinect "$OUT/kinect.list"
  cases="$cases kinect"
else
  log "no real data ($KINECT): the Kinect row is left out"
fi

COMMIT="$(git -C "$REPO" rev-parse --short HEAD 2>/dev/null || echo unknown)"
/usr/bin/python3 - "$OUT" "$COMMIT" $cases > "$OUT/profile.md" <<'PY'
import re, sys
out, commit, cases = sys.argv[1], sys.argv[2], sys.argv[3:]
label = {"suite": "20 suite scenes, 30k points each",
         "office": "the 300k office sweep",
         "kinect": "the Kinect pair, 307k organised"}
search = re.compile(r"KnnTree::(search|within|forEachNeighbourhood|nearestDistance|"
                    r"kthNearestDistance|atLeast|anyWithin)")
build = re.compile(r"KnnTree::(split|buildSubtree|nodeOver|KnnTree)\b")


def short_name(dso, symbol):
    """A readable name: no namespaces, arguments or template arguments."""
    if dso.startswith("ld-linux"):
        return "dynamic loader (process start)"
    if re.match(r"__(memset|memmove|memcpy)", symbol):
        return "memset, memmove (libc)"
    name = symbol.replace("(anonymous namespace)::", "")
    while re.search(r"<[^<>]*>", name):
        name = re.sub(r"<[^<>]*>", "", name)
    name = re.sub(r"\(.*", "", name)
    for prefix in ("novelty_detection::", "detail::", "internal::", "lemon::", "ceres::",
                   "Eigen::", "std::"):
        name = name.replace(prefix, "")
    return name.strip() or symbol[:40]
print(f"Commit {commit}, one thread, `bash scripts/profile.sh`: self time of the hottest "
      "functions (`--sort symbol`), share of all samples of the detector's processes:")
print()
print("| cloud | neighbour searches (`KnnTree`) | kd-tree builds | kernel (page faults) | next |")
print("|---|---:|---:|---:|---|")
for case in cases:
    groups = {"search": 0.0, "build": 0.0, "kernel": 0.0}
    others = []
    for line in open(f"{out}/{case}.txt"):
        m = re.match(r"\s*([\d.]+)%\s+(\S+)\s+\[(.)\]\s+(.*)", line)
        if not m:
            continue
        share, dso, kind = float(m.group(1)), m.group(2), m.group(3)
        symbol = re.sub(r"\s+-\s+-\s*$", "", m.group(4)).strip()  # perf's empty columns
        if kind == "k":
            groups["kernel"] += share
        elif search.search(symbol):
            groups["search"] += share
        elif build.search(symbol):
            groups["build"] += share
        else:
            others.append((share, short_name(dso, symbol)))
    merged = {}
    for share, name in others:
        merged[name] = merged.get(name, 0.0) + share
    top = sorted(merged.items(), key=lambda kv: -kv[1])[:5]
    nxt = ", ".join(f"`{n}` {s:.1f} %" for n, s in top)
    print(f"| {label[case]} | {groups['search']:.0f} % | {groups['build']:.0f} % | "
          f"{groups['kernel']:.0f} % | {nxt} |")
PY
log "wrote $OUT/profile.md"
if [ "$DOCS_UPDATE" = 1 ]; then
  docs_table profile-table "$OUT/profile.md"
fi
