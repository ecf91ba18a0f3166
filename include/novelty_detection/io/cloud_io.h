// Reading and writing point cloud files (PCD, PLY) with clear errors. ROS-free.
#pragma once

#include <cstdint>
#include <limits>
#include <string>

#include "novelty_detection/types.h"

namespace novelty_detection {

/// A cloud and the sensor pose stored with it (PCD VIEWPOINT; identity when absent).
struct CloudFile {
  Cloud cloud;
  Eigen::Isometry3d T_frame_sensor = Eigen::Isometry3d::Identity();
};

/// What a file may hold, checked on its header before its body is read or allocated: a
/// refusal names the limit and the parameter that sets it.
struct LoadLimits {
  /// More points than this are refused (callers pass preprocess/max_points).
  std::uint64_t max_points = std::numeric_limits<std::uint64_t>::max();
  /// The parameter named in a refusal.
  std::string parameter = "preprocess/max_points";
  /// Point records may hold other fields; at most this many bytes per allowed point are read
  /// (bounds the time spent on a body, e.g. an LZF block, whatever its fields).
  static constexpr std::uint64_t kBytesPerPoint = 256;
};

/// Loads a .pcd or .ply file with at least float x, y, z fields (other fields ignored,
/// NaN points kept so indices match the file, WIDTH x HEIGHT kept). PCD files (ascii,
/// binary, binary_compressed) go through a strict reader of our own that checks every
/// byte against the header; PLY headers are checked before PCL's reader sees them. Throws
/// std::runtime_error with a one-line message naming the file and the problem (missing, unreadable,
/// truncated, no x/y/z, unknown extension, over `limits`).
CloudFile loadCloudFile(const std::string& path, const LoadLimits& limits = {});
Cloud loadCloud(const std::string& path, const LoadLimits& limits = {});

/// Writes a binary PCD (x, y, z) atomically and durably: to a new temporary file beside
/// `path` (mkstemp: a random name opened exclusively, so nothing planted there is followed),
/// flushed to disk, renamed over `path`, and the directory flushed; a failed save leaves a
/// previous file intact and no temporary file behind. The sensor pose goes to VIEWPOINT.
/// Throws std::runtime_error naming the path, the step and the system's reason on failure.
void saveCloudAtomic(const std::string& path, const Cloud& cloud,
                     const Eigen::Isometry3d& T_frame_sensor = Eigen::Isometry3d::Identity());

}  // namespace novelty_detection
