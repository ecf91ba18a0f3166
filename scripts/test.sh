#!/usr/bin/env bash
# Installs what is missing, builds, runs every gtest and rostest, fails on any failure.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
bash "$REPO/scripts/install_deps.sh"
bash "$REPO/scripts/build.sh"
cd "$WS"
rm -rf "$WS/build/test_results"
log "running tests"
set +e
catkin_make run_tests -j"${NOVELTY_JOBS:-2}" > "$WS/test.log" 2>&1
run_rc=$?
set -e
grep -E "^\[ *(OK|FAILED|PASSED) *\]|^\[ RUN|FAILURE|ERROR:" "$WS/test.log" | grep -v "^\[ RUN" || true
if [ $run_rc -ne 0 ]; then
  tail -80 "$WS/test.log" >&2
  log "catkin_make run_tests failed (log: $WS/test.log)"
fi
# Prints "Summary: N tests, N errors, N failures, N skipped" and fails on any of them.
catkin_test_results "$WS/build/test_results"
exit $run_rc
