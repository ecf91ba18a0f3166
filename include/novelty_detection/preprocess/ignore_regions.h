// Ignore regions: boxes of the map frame where changes are not reported. ROS-free.
//
// A patrol route has places that change all the time and matter to nobody: a parking spot,
// a door that is always moving, a desk where things come and go. preprocess/ignore_regions
// lists them as boxes in the reference's (map) frame. Current points inside one are taken as
// missing before the comparison (counted in Result::ignored_points; never novel, never newly
// visible), and a disappearance whose centroid lies inside one is not reported.
//
// Text form: boxes separated by ';', each six or seven numbers
//   "xmin ymin zmin xmax ymax zmax"          an axis-aligned box [m]
//   "xmin ymin zmin xmax ymax zmax yaw_deg"  that box turned by yaw_deg about the vertical
//                                            (z) axis through its centre
// e.g. "2 -1 0 3 1 2.2; 10 4 0 12 6 2 30". Empty text: no region.
#pragma once

#include <Eigen/Geometry>

#include <string>
#include <vector>

#include "novelty_detection/types.h"

namespace novelty_detection {

/// One (possibly turned) box of the map frame.
struct IgnoreRegion {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d half_extent = Eigen::Vector3d::Zero();  ///< half edge lengths, box axes
  double yaw_rad = 0.0;                                   ///< turn about +z through centre

  /// Whether p (map frame) lies inside or on the box.
  bool contains(const Eigen::Vector3d& p) const;
};

/// Parses the text form above. Throws std::invalid_argument naming preprocess/ignore_regions,
/// the offending box and what is wrong (count of numbers, min > max, non-finite values).
std::vector<IgnoreRegion> parseIgnoreRegions(const std::string& text);

/// The text form of regions (axis-aligned ones without a yaw), parseable again.
std::string formatIgnoreRegions(const std::vector<IgnoreRegion>& regions);

/// Whether p lies in any of the regions.
bool inIgnoreRegion(const std::vector<IgnoreRegion>& regions, const Eigen::Vector3d& p);

/// Sets every finite point of `cloud` inside a region to NaN (order kept, is_dense false
/// when any) and returns how many.
std::size_t maskIgnoreRegions(const std::vector<IgnoreRegion>& regions, Cloud& cloud);

/// Drops from `result` the disappearances whose centroid lies in a region (their segments,
/// their disappeared_labels, their superquadrics); returns how many.
std::size_t dropDisappearancesIn(const std::vector<IgnoreRegion>& regions, Result* result);

}  // namespace novelty_detection
