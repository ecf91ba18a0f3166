// The angle between a sweep's successive scan lines, per bearing (ROS-free).
//
// A tilting laser samples densely along each line (its beams, 0.25 deg apart on a UTM-30LX)
// and sparsely across lines (the tilt step, 2-3 deg); a rotating laser the other way round; a
// depth camera evenly. The vertical gap between two lines on an object is that step times the
// range: ten times the spacing along a line and more, and independent of the range noise that
// widens the link radius. Seen from the sensor, the returns of one bearing bin (kBinRad of
// azimuth) sorted by elevation are runs of one line each (the few beams of a line within the
// bin lie at nearly one elevation) separated by the step; the step is the median of the
// elevation gaps larger than the bin's mean gap (those between lines). Where lines converge
// (a tilting laser's sides) or samples are too few, the step found is small or zero: nothing
// there is a gap between lines.
#pragma once

#include <Eigen/Core>

#include <unordered_map>
#include <vector>

#include "novelty_detection/types.h"

namespace novelty_detection {

class ScanLineSpacing {
 public:
  /// Azimuth bin width [rad] (0.5 deg): a few beams of each line per bin at a laser's
  /// 0.25 deg, and little change of a slanted line's elevation across it.
  static constexpr double kBinRad = 0.5 * 3.14159265358979323846 / 180.0;
  /// A bin needs this many returns for a step.
  static constexpr int kMinBinPoints = 8;

  ScanLineSpacing() = default;
  /// Over the finite points of `cloud` seen from `origin`. The cloud is referenced, not
  /// copied: it must outlive this object. A bin's step is measured when first asked for (one
  /// pass over the points) and kept.
  ScanLineSpacing(const Cloud& cloud, const Eigen::Vector3f& origin);

  /// The elevation step between successive scan lines at bearing `azimuth` [rad] (0 when
  /// unknown).
  double stepAt(double azimuth) const;

  /// Bearing atan2(y, x) and elevation of p about `origin` (z up) [rad].
  static double azimuthOf(const Eigen::Vector3f& p, const Eigen::Vector3f& origin);
  static double elevationOf(const Eigen::Vector3f& p, const Eigen::Vector3f& origin);

 private:
  const Cloud* cloud_ = nullptr;
  Eigen::Vector3f origin_ = Eigen::Vector3f::Zero();
  mutable std::unordered_map<int, float> steps_;  ///< per azimuth bin measured so far
};

}  // namespace novelty_detection
