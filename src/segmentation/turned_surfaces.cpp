// Surfaces that turned (segmentation/turned_surfaces.h).
#include "novelty_detection/segmentation/turned_surfaces.h"

#include <algorithm>
#include <cmath>

namespace novelty_detection {

HorizontalDirection horizontalDirection(const NearestNeighbourIndex::Neighbourhood& n) {
  HorizontalDirection out;
  out.points = n.count;
  const double sxx = n.covariance(0, 0), syy = n.covariance(1, 1), sxy = n.covariance(0, 1);
  const double trace = sxx + syy;
  if (n.count < 2 || !(trace > 0.0)) return out;
  // Eigenvalues of the 2x2 covariance: l1 - l2 = sqrt((sxx - syy)^2 + 4 sxy^2).
  const double spread = std::hypot(sxx - syy, 2.0 * sxy);
  out.angle_rad = 0.5 * std::atan2(2.0 * sxy, sxx - syy);
  out.line_share = std::min(1.0, spread / trace);
  return out;
}

double directionAngleDeg(const HorizontalDirection& a, const HorizontalDirection& b) {
  // Doubled angles compare directions modulo pi.
  const double c = std::cos(2.0 * (a.angle_rad - b.angle_rad));
  return 0.5 * std::acos(std::clamp(c, -1.0, 1.0)) * 180.0 / M_PI;
}

namespace {
bool hasDirection(const HorizontalDirection& d) {
  return d.points >= kMinDirectionPoints && d.line_share >= kMinLineShare;
}
}  // namespace

bool surfaceTurned(const Eigen::Vector3f& p, const NearestNeighbourIndex& sweep,
                   const NearestNeighbourIndex& map, double radius_m, double min_angle_deg) {
  if (!(radius_m > 0.0)) return false;
  const HorizontalDirection here = horizontalDirection(sweep.neighbourhood(p, radius_m));
  if (!hasDirection(here)) return false;
  const HorizontalDirection before = horizontalDirection(map.neighbourhood(p, radius_m));
  if (!hasDirection(before)) return false;
  // Sampled alike: where one holds more than kMaxSamplingRatio times the other's points, the
  // two saw the place differently (another viewpoint, a part hidden from one of them).
  const double here_n = static_cast<double>(here.points),
               before_n = static_cast<double>(before.points);
  if (here_n > kMaxSamplingRatio * before_n || before_n > kMaxSamplingRatio * here_n) return false;
  return directionAngleDeg(here, before) > min_angle_deg;
}

}  // namespace novelty_detection
