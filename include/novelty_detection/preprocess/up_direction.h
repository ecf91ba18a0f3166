// Which way is up (preprocess/up). ROS-free.
//
// Everything that assumes "up" (the ground plane, the floor footprints of segmentation, the
// superquadrics' frames) works in a frame whose +z is up: the pipeline rotates both clouds
// into it about the origin (rotationToZUp) and its results back. The default up is +z, the
// ROS convention (REP 103); "auto" estimates it from the reference:
//
//   Planes are found by sequential RANSAC on a sample of the cloud (inlier distance 2 % of
//   the median range from the sensor, 1-10 cm). Each plane's normal is oriented towards the
//   sensor origin (towards most points without one). A plane can be the floor when the
//   sensor lies above it, at most 5 % of the points lie beneath it (a floor or a table top
//   bounds the scene from below; a table in a room has the floor beneath it) and its normal
//   is within 45 degrees of a nominal up: +z, and for an organised cloud (a depth camera in
//   its optical frame: x right, y down, z forward) also -y. Of those, the one with the most
//   points gives up; without one, the nominal +z is kept and the estimate says so.
#pragma once

#include <string>

#include "novelty_detection/types.h"

namespace novelty_detection {

/// preprocess/up as parsed: "auto", or three numbers (the up vector in the clouds' frame).
struct UpSetting {
  bool automatic = false;
  Eigen::Vector3d vector = Eigen::Vector3d::UnitZ();  ///< unit, when not automatic
};

/// Throws std::invalid_argument unless `text` is "auto" or three finite numbers, not all 0.
UpSetting parseUp(const std::string& text);

struct UpEstimate {
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();  ///< unit vector in the cloud's frame
  /// "given" (preprocess/up), "plane" (the normal of a floor plane found in the data) or
  /// "nominal" (auto found no floor plane: +z assumed).
  std::string source = "given";
  double plane_share = 0.0;  ///< share of the sampled points on that plane ("plane")
};

/// The up direction for `setting`; estimated from `cloud` when automatic (rule above).
UpEstimate resolveUp(const UpSetting& setting, const Cloud& cloud);

/// The smallest rotation taking `up` (unit) to +z; the identity when up is +z.
Eigen::Matrix3d rotationToZUp(const Eigen::Vector3d& up);

}  // namespace novelty_detection
