// A strict reader of PCD files (ascii, binary, binary_compressed) for the x, y, z fields.
//
// PCL's PCDReader trusts what a header says about its body and reads past buffers or
// allocates without bound on inconsistent files (found by fuzzing). Files on a robot come
// from disks that fill up, copies that stop half way and tools with their own ideas of the
// format, so every byte read here is bounds-checked against the file and the header:
// declarations once each, per-field lists of equal length, WIDTH * HEIGHT == POINTS, a body
// exactly as long as declared (ascii: POINTS lines of sum(COUNT) numbers; compressed: an LZF
// block that expands to exactly POINTS * point size bytes), and within the caller's limits
// before anything the size of the body is allocated.
#pragma once

#include <cstdint>
#include <string>

#include "novelty_detection/io/cloud_io.h"

namespace novelty_detection {
namespace detail {

/// Reads `path` (a regular file of `file_size` bytes). x, y, z must be F 4 or F 8 fields;
/// other fields are skipped. Keeps WIDTH x HEIGHT and NaN points. `limits` are checked on the
/// header before the body is read; memory stays about the size of the kept x, y, z (a
/// compressed body is decoded as a stream, never expanded whole). Throws std::runtime_error
/// "cannot read '<path>': <problem>".
CloudFile readPcdFile(const std::string& path, std::uintmax_t file_size, const LoadLimits& limits);

}  // namespace detail
}  // namespace novelty_detection
