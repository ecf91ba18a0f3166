// Scan-line spacing per bearing (segmentation/scan_lines.h).
#include "novelty_detection/segmentation/scan_lines.h"

#include <algorithm>
#include <cmath>

namespace novelty_detection {

namespace {

constexpr double kPi = 3.14159265358979323846;

int binCount() { return static_cast<int>(std::ceil(2.0 * kPi / ScanLineSpacing::kBinRad)); }

int binOf(double azimuth) {
  const int n = binCount();
  const int b = static_cast<int>(std::floor((azimuth + kPi) / ScanLineSpacing::kBinRad));
  return std::clamp(b, 0, n - 1);
}

/// The median of the gaps between sorted elevations that exceed their mean gap.
float lineStep(std::vector<float>* elevations) {
  if (static_cast<int>(elevations->size()) < ScanLineSpacing::kMinBinPoints) return 0.f;
  std::sort(elevations->begin(), elevations->end());
  const float span = elevations->back() - elevations->front();
  const float mean = span / static_cast<float>(elevations->size() - 1);
  std::vector<float> large;
  for (std::size_t k = 1; k < elevations->size(); ++k) {
    const float g = (*elevations)[k] - (*elevations)[k - 1];
    if (g > mean) large.push_back(g);
  }
  if (large.empty()) return 0.f;
  std::nth_element(large.begin(), large.begin() + large.size() / 2, large.end());
  return large[large.size() / 2];
}

}  // namespace

double ScanLineSpacing::azimuthOf(const Eigen::Vector3f& p, const Eigen::Vector3f& origin) {
  return std::atan2(static_cast<double>(p.y() - origin.y()),
                    static_cast<double>(p.x() - origin.x()));
}

double ScanLineSpacing::elevationOf(const Eigen::Vector3f& p, const Eigen::Vector3f& origin) {
  const Eigen::Vector3d d = (p - origin).cast<double>();
  return std::atan2(d.z(), d.head<2>().norm());
}

ScanLineSpacing::ScanLineSpacing(const Cloud& cloud, const Eigen::Vector3f& origin)
    : cloud_(&cloud), origin_(origin) {}

double ScanLineSpacing::stepAt(double azimuth) const {
  if (!cloud_ || !std::isfinite(azimuth)) return 0.0;
  const int bin = binOf(azimuth);
  const auto found = steps_.find(bin);
  if (found != steps_.end()) return found->second;
  // The bin's returns: directions on the floor plan between its two edges (cross products,
  // no angle per point), on its side of the origin.
  const double lo = -kPi + bin * kBinRad, hi = lo + kBinRad, mid = 0.5 * (lo + hi);
  const Eigen::Vector2d u_lo(std::cos(lo), std::sin(lo)), u_hi(std::cos(hi), std::sin(hi));
  const Eigen::Vector2d u_mid(std::cos(mid), std::sin(mid));
  std::vector<float> elevations;
  for (const PointT& q : *cloud_) {
    const Eigen::Vector3f p = q.getVector3fMap();
    if (!p.allFinite()) continue;
    const Eigen::Vector2d v = (p - origin_).head<2>().cast<double>();
    if (v.dot(u_mid) <= 0.0 || u_lo.x() * v.y() - u_lo.y() * v.x() < 0.0 ||
        v.x() * u_hi.y() - v.y() * u_hi.x() <= 0.0)
      continue;
    elevations.push_back(static_cast<float>(elevationOf(p, origin_)));
  }
  const float step = lineStep(&elevations);
  steps_.emplace(bin, step);
  return step;
}

}  // namespace novelty_detection
