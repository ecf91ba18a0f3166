#!/usr/bin/env bash
# Soak: N sweeps (default 1000, one in five bad) through the detector nodelet in a real
# manager (test/ros/soak.test); prints the counters and the manager's RSS, threads and fds.
#   scripts/soak.sh [N]
# Needs a build (scripts/build.sh). Fails when a good sweep has no result, a bad one is not
# counted, RSS grows by 20 MB or more between sweep 100 and sweep N, or threads/fds grow.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
N="${1:-1000}"
[ -x "$WS/devel/lib/novelty_detection/test_soak" ] || {
  log "building test_soak"
  bash "$REPO/scripts/build.sh" test_soak
}
source_devel
# Against a sanitized workspace (NOVELTY_SANITIZE=ON): preload ASan into the manager and keep
# its quarantine small so that RSS measures the package, not ASan's freed-memory cache.
if [ "${NOVELTY_SANITIZE:-OFF}" = ON ]; then
  export LD_PRELOAD="$(${CXX:-c++} -print-file-name=libasan.so)"
  export ASAN_OPTIONS="detect_leaks=0:abort_on_error=1:quarantine_size_mb=1:${ASAN_OPTIONS:-}"
fi
# Under a slow or shared machine a sweep takes up to ~1 s; allow that plus start-up.
LIMIT=$((N + 120))
log "soak: $N sweeps (time limit ${LIMIT}s)"
start=$(date +%s)
set +e
rostest --text novelty_detection soak.test sweeps:="$N" time_limit:="$LIMIT" > "$WS/soak.log" 2>&1
rc=$?
set -e
grep -E "^soak:|\[ *(OK|FAILED|PASSED) *\]|Failure|Expected|Which is|FAILURE|ERROR" "$WS/soak.log" || true
log "soak finished in $(( $(date +%s) - start ))s (log: $WS/soak.log)"
exit "$rc"
