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
# A sanitized build: the nodelet manager and python's rostest are not instrumented but load
# instrumented libraries, so the ASan runtime is preloaded into the test processes only.
preload=()
if [ "${NOVELTY_SANITIZE:-OFF}" = ON ]; then
  preload=(env LD_PRELOAD="$(${CXX:-c++} -print-file-name=libasan.so)")
fi
"${preload[@]}" catkin_make run_tests -j"${NOVELTY_JOBS:-2}" > "$WS/test.log" 2>&1
run_rc=$?
set -e
grep -E "^\[ *(OK|FAILED|PASSED) *\]|^\[ RUN|FAILURE|ERROR:" "$WS/test.log" | grep -v "^\[ RUN" || true
# The head of each failed check's message (the whole of it stays in the log).
awk '/: Failure$/ { n = 16 } n > 0 { print substr($0, 1, 300); n-- }' "$WS/test.log" | head -200
if [ $run_rc -ne 0 ]; then
  tail -80 "$WS/test.log" >&2
  log "catkin_make run_tests failed (log: $WS/test.log)"
fi
# catkin_test_results prints "Summary: N tests, N errors, N failures, N skipped" and fails
# on any of them; the last line restates it as "tests: N passed, N failed, N skipped".
set +e
summary=$(catkin_test_results "$WS/build/test_results")
results_rc=$?
set -e
echo "$summary"
read -r total errors failures skipped < <(echo "$summary" | sed -n \
  's/^Summary: \([0-9]*\) tests, \([0-9]*\) errors, \([0-9]*\) failures, \([0-9]*\) skipped.*/\1 \2 \3 \4/p' | tail -1) || true
total=${total:-0}; errors=${errors:-0}; failures=${failures:-0}; skipped=${skipped:-0}
failed=$((errors + failures))
[ $run_rc -ne 0 ] && [ $failed -eq 0 ] && failed=1
echo "tests: $((total - failed - skipped)) passed, $failed failed, $skipped skipped"
[ $run_rc -ne 0 ] && exit $run_rc
exit $results_rc
