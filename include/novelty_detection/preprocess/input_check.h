// What the detector accepts as a measurement, and whether two clouds can be compared.
// ROS-free.
//
// A finite coordinate is not always a measurement: a corrupt or uninitialised buffer holds
// values like 1e20 m, which wreck every scale estimated from the data (the outlier
// statistic, voxel and tile indices, the novelty threshold). A point with a coordinate
// beyond kMaxCoordinateM (100 km; float32 resolves no better than 8 mm there) is treated as
// missing, like NaN, and counted. A sweep that lies mostly outside the reference's extent
// (wrong frame, lost localisation) cannot be compared: the detector says so instead of
// answering "no change".
#pragma once

#include <Eigen/Geometry>

#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>

#include "novelty_detection/types.h"

namespace novelty_detection {

/// Largest accepted |x|, |y| or |z| of a point [m].
constexpr float kMaxCoordinateM = 1e5f;

/// Finite and within kMaxCoordinateM on every axis.
inline bool usablePoint(const PointT& p) {
  return std::abs(p.x) <= kMaxCoordinateM && std::abs(p.y) <= kMaxCoordinateM &&
         std::abs(p.z) <= kMaxCoordinateM;  // false for NaN too
}

/// Points that are finite but beyond kMaxCoordinateM.
std::size_t countOutOfRange(const Cloud& cloud);

/// A copy of `cloud` with its out-of-range points made NaN (same size and order).
Cloud withoutOutOfRange(const Cloud& cloud);

/// `cloud` itself when every finite point is usable, else withoutOutOfRange(cloud) kept in
/// `storage`; `out_of_range` gets the count.
const Cloud& usableView(const Cloud& cloud, Cloud* storage, std::size_t* out_of_range);

/// Box of the usable points (empty box when there is none).
Eigen::AlignedBox3d usableExtent(const Cloud& cloud);

/// Throws std::invalid_argument "`who`: index i outside a cloud of N points" unless
/// 0 <= index < cloud.size().
void requireIndexInCloud(const Cloud& cloud, int index, const char* who);

/// Throws std::invalid_argument when the usable points of `cloud` span less than 1 mm (all
/// in one place: no map to compare with), naming `what` ("reference").
void requireExtent(const Cloud& cloud, const char* what);

/// Box of the usable points of `cloud` (finite, within kMaxCoordinateM); false when there is
/// none. Safe to grow and to turn into tile indices.
bool usableBounds(const Cloud& cloud, Eigen::Vector3d& lo, Eigen::Vector3d& hi);

/// Share of the usable points of `cloud` inside `extent` grown by `margin_m` on every side.
double shareInside(const Cloud& cloud, const Eigen::AlignedBox3d& extent, double margin_m);

/// The sweep and the reference cannot be compared; overlap() is the share of the sweep's
/// points near the map (as in Result::overlap).
class NoOverlapError : public std::runtime_error {
 public:
  NoOverlapError(const std::string& what, double overlap)
      : std::runtime_error(what), overlap_(overlap) {}
  double overlap() const { return overlap_; }

 private:
  double overlap_;
};

/// Below this share of the sweep's points near the map (overlapDistance), it is refused.
constexpr double kMinOverlap = 0.05;

/// How near a point must be to the map to count as overlapping it: a hundredth of the
/// reference's extent (10 cm in a 10 m room, 1 cm on a 1 m tabletop), at least `floor_m`.
double overlapDistance(const Eigen::AlignedBox3d& reference_extent, double floor_m);

/// Throws NoOverlapError when under a quarter of the sweep's usable points lie within the
/// reference's extent grown by a tenth of its diagonal, or when `overlap` (the share of its
/// points within overlapDistance of the map) is below kMinOverlap: the sweep is not of the
/// mapped place (or not in its frame) and no answer would be honest.
void requireOverlap(const Cloud& sweep, const Eigen::AlignedBox3d& reference_extent,
                    double overlap);

}  // namespace novelty_detection
