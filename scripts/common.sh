# Sourced by the other scripts: paths and the ROS environment for an out-of-tree catkin
# workspace in .ws/ (git-ignored) at the repository root.
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
WS="${NOVELTY_WS:-$REPO/.ws}"
# Debian's catkin needs the system python (a pyenv shim may come first in PATH).
export PATH="/usr/bin:/bin:$PATH"
export ROS_HOME="$WS/.ros_home"
export ROS_LOG_DIR="$ROS_HOME/log"
mkdir -p "$ROS_LOG_DIR"

log() { printf '\033[1m[novelty_detection]\033[0m %s\n' "$*" >&2; }

# Builds the named targets (scripts/build.sh) unless NOVELTY_SKIP_BUILD=1.
build_tools() {
  if [ "${NOVELTY_SKIP_BUILD:-0}" != 1 ]; then bash "$REPO/scripts/build.sh" "$@"; fi
}

# Sources the devel space (its scripts read unset variables, so -u is lifted around it).
source_devel() {
  local had_u=0
  case $- in *u*) had_u=1; set +u ;; esac
  # shellcheck disable=SC1091
  source "$WS/devel/setup.bash"
  [ "$had_u" = 1 ] && set -u
  return 0
}

# Real scans for test/real and scripts/evaluate_real.sh: NOVELTY_REAL_DATA, else the shared
# data set beside the repository when it is there (shared/data/real).
if [ -z "${NOVELTY_REAL_DATA:-}" ] && [ -d "$REPO/../shared/data/real" ]; then
  NOVELTY_REAL_DATA="$(cd "$REPO/../shared/data/real" && pwd)"
fi
export NOVELTY_REAL_DATA="${NOVELTY_REAL_DATA:-}"

# The suites' range noise: NOVELTY_SUITE_NOISE_VAR (variance [m^2], the simulator's default,
# the paper's 0.001, when unset) for run_suite.sh and evaluate_viewpoint.sh.
# suite_noise_args fills SUITE_NOISE_ARGS for simulate_scans; suite_noise_matches DIR says
# whether the suite simulated in DIR has that noise.
suite_noise_args() {
  SUITE_NOISE_ARGS=()
  local v="${NOVELTY_SUITE_NOISE_VAR:-}"
  [ -z "$v" ] && return 0
  case "$v" in
    *[!0-9.eE+-]*) log "NOVELTY_SUITE_NOISE_VAR: '$v' is not a variance in m^2"; exit 2 ;;
  esac
  # shellcheck disable=SC2034  # read by the scripts that source this file
  SUITE_NOISE_ARGS=(--noise-var "$v")
}
suite_noise_matches() {
  local want="${NOVELTY_SUITE_NOISE_VAR:-0.001}"
  [ -f "$1/scene_000/scene.json" ] &&
    grep -Eq "\"noise_variance_m2\": ${want//./\\.},?$" "$1/scene_000/scene.json"
}

# simulate_once DIR ARGS...: simulate_scans ARGS (without a bag) into DIR, unless DIR holds
# scenes the current simulate_scans made (DIR/.done newer than the program).
simulate_once() {
  local dir="$1" sim="$WS/devel/lib/novelty_detection/simulate_scans"
  shift
  if [ ! -f "$dir/.done" ] || [ "$dir/.done" -ot "$sim" ]; then
    rm -rf "$dir"
    log "simulating $dir"
    "$sim" --out "$dir" "$@" --no-bag > /dev/null
    touch "$dir/.done"
  fi
}

# docs_table NAME FILE: FILE becomes the text of docs/evaluation.md between its markers
# <!-- NAME:begin --> and <!-- NAME:end --> (a warning, nothing written, without them).
docs_table() {
  /usr/bin/python3 - "$REPO/docs/evaluation.md" "$1" "$2" <<'PY'
import sys
doc, name, path = sys.argv[1:4]
table = open(path).read().rstrip("\n")
begin, end = f"<!-- {name}:begin -->", f"<!-- {name}:end -->"
text = open(doc).read()
if begin in text and end in text:
    a, b = text.index(begin) + len(begin), text.index(end)
    open(doc, "w").write(text[:a] + "\n" + table + "\n" + text[b:])
    print(f"docs/evaluation.md: {name} updated", file=sys.stderr)
else:
    print(f"docs/evaluation.md: no {name} markers, not updated", file=sys.stderr)
PY
}
