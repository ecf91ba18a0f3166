#!/usr/bin/env bash
# The whole test suite (gtests and rostests) under AddressSanitizer + UndefinedBehaviorSanitizer
# (with float-cast-overflow: a float beyond an integer type's range converted to it),
# in its own workspace so that it never mixes with the normal build:
#   scripts/test_sanitizers.sh            (workspace: $NOVELTY_WS, default /tmp/novelty_sanitize_ws)
# Any ASan report or UBSan finding aborts the process and so fails its test.
#  - detect_leaks=0: LeakSanitizer would also run in every process of the test run, and the
#    ROS ones leak at exit by design (python's rostest/roslaunch, the nodelet manager keeps
#    class_loader's plugin libraries and roscpp's singletons alive); leaks inside the package
#    are covered by the soak's RSS bound instead.
#  - NOVELTY_SOAK_MAX_RSS_GROWTH_MB=300: ASan keeps freed memory in a quarantine (256 MB by
#    default) to catch use after free, so the manager's RSS grows until that is full.
#  - alloc_dealloc_mismatch=0: Debian's PCL is built as C++14, where Eigen's aligned
#    operator new/delete (malloc/free) are class members; our C++17 code allocates the same
#    classes with the plain operator new. On glibc both are malloc, but ASan reports the pair.
#  - EIGEN_MALLOC_ALREADY_ALIGNED (CMakeLists.txt): the same agreement for Eigen's buffers.
set -euo pipefail
export NOVELTY_WS="${NOVELTY_WS:-${TMPDIR:-/tmp}/novelty_sanitize_ws}"
export NOVELTY_SANITIZE=ON
export NOVELTY_BUILD_TYPE="${NOVELTY_BUILD_TYPE:-RelWithDebInfo}"
export ASAN_OPTIONS="detect_leaks=0:abort_on_error=1:alloc_dealloc_mismatch=0:${ASAN_OPTIONS:-}"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1:${UBSAN_OPTIONS:-}"
export NOVELTY_SOAK_MAX_RSS_GROWTH_MB="${NOVELTY_SOAK_MAX_RSS_GROWTH_MB:-300}"
here="$(dirname "${BASH_SOURCE[0]}")"
start=$(date +%s)
# Benchmarks are not tests: skip building them here.
bash "$here/build.sh" -DNOVELTY_BUILD_BENCHMARKS=OFF
bash "$here/test.sh"
echo "sanitizer suite wall time: $(( $(date +%s) - start ))s"
