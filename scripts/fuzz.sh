#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (ASan + UBSan) and runs each for a fixed time.
#   scripts/fuzz.sh [SECONDS_PER_TARGET]   (default 60)
# NOVELTY_FUZZ_TARGETS="fuzz_pointcloud2" runs only the named targets (all are built).
# Findings are written to .ws/fuzz/<target>/ (crash-*, timeout-*); copy a minimised one to
# test/fuzz/corpus/<target>/ and add a regression test when fixing it.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
SECONDS_PER_TARGET="${1:-60}"
command -v clang++ >/dev/null || { echo "clang++ is needed for fuzzing (apt-get install clang)" >&2; exit 1; }
OUT="$WS/fuzz"
BIN="$OUT/bin"
mkdir -p "$BIN"
PCL_INC=$(ls -d /usr/include/pcl-1.* | tail -1)
CXXFLAGS=(-std=c++17 -O1 -g -fsanitize=fuzzer,address,undefined -fno-omit-frame-pointer
  -I"$REPO/include" -I"$REPO/src" -isystem "$PCL_INC" -isystem /usr/include/eigen3)
build_target() {  # name, sources...
  local name=$1; shift
  log "building $name"
  clang++ "${CXXFLAGS[@]}" "$@" -o "$BIN/$name" -lpcl_io -lpcl_common \
    -lboost_system -lboost_filesystem
}
build_target fuzz_cloud_file "$REPO/test/fuzz/fuzz_cloud_file.cpp" "$REPO/src/io/cloud_io.cpp" \
  "$REPO/src/io/pcd_reader.cpp"
# Message headers are header-only; rostime/roscpp_serialization hold the few out-of-line bits.
build_target fuzz_pointcloud2 "$REPO/test/fuzz/fuzz_pointcloud2.cpp" "$REPO/src/ros/conversions.cpp" \
  -lroscpp_serialization -lrostime
# The sweep path: conversion, the reference's tiles and the whole detector (the core's
# sources as CMakeLists.txt lists them).
mapfile -t CORE < <(sed -n '/^set(CORE_SOURCES/,/)/p' "$REPO/CMakeLists.txt" | tr ' ()' '\n\n\n' |
  grep '^src/.*\.cpp$' | sed "s|^|$REPO/|")
LEMON_INC=$(pkg-config --cflags lemon 2>/dev/null || true)
build_target fuzz_sweep_path "$REPO/test/fuzz/fuzz_sweep_path.cpp" "$REPO/src/ros/conversions.cpp" \
  "$REPO/src/ros/tiled_reference.cpp" "${CORE[@]}" -isystem /usr/include/ceres $LEMON_INC \
  -lroscpp_serialization -lrostime -lpcl_kdtree -lpcl_search -lpcl_filters -lpcl_segmentation \
  -lpcl_octree -lceres -lglog -lgflags -lspqr -lcholmod -lccolamd -lcamd -lcolamd -lamd \
  -lcxsparse -lsuitesparseconfig -llapack -lblas -ltbb -llemon -lpthread
TARGETS="${NOVELTY_FUZZ_TARGETS:-fuzz_cloud_file fuzz_pointcloud2 fuzz_sweep_path}"
for target in $TARGETS; do
  corpus_src="$REPO/test/fuzz/corpus/${target#fuzz_}"
  work="$OUT/$target"
  mkdir -p "$work/corpus"
  cp -n "$corpus_src"/* "$work/corpus/" 2>/dev/null || true
  log "running $target for ${SECONDS_PER_TARGET}s"
  (cd "$work" && "$BIN/$target" -max_total_time="$SECONDS_PER_TARGET" -timeout=10 \
    -rss_limit_mb=2048 -max_len=65536 -print_final_stats=1 corpus > "$work/log.txt" 2>&1) || {
    tail -40 "$work/log.txt" >&2
    log "$target found a problem (see $work)"
    exit 1
  }
  grep -E "stat::number_of_executed_units|Done" "$work/log.txt" | tail -2 >&2
done
log "fuzzing finished without findings"
