#include "novelty_detection/preprocess/input_check.h"

#include <algorithm>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>

namespace novelty_detection {

std::size_t countOutOfRange(const Cloud& cloud) {
  std::size_t n = 0;
  for (const PointT& p : cloud)
    n += std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z) && !usablePoint(p);
  return n;
}

Cloud withoutOutOfRange(const Cloud& cloud) {
  Cloud out = cloud;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (PointT& p : out)
    if (!usablePoint(p)) p.x = p.y = p.z = nan;
  out.is_dense = false;
  return out;
}

const Cloud& usableView(const Cloud& cloud, Cloud* storage, std::size_t* out_of_range) {
  *out_of_range = countOutOfRange(cloud);
  if (*out_of_range == 0) return cloud;
  *storage = withoutOutOfRange(cloud);
  return *storage;
}

Eigen::AlignedBox3d usableExtent(const Cloud& cloud) {
  Eigen::AlignedBox3d box;
  for (const PointT& p : cloud)
    if (usablePoint(p)) box.extend(p.getVector3fMap().cast<double>());
  return box;
}

void requireExtent(const Cloud& cloud, const char* what) {
  const Eigen::AlignedBox3d box = usableExtent(cloud);
  if (box.isEmpty()) return;  // no usable point: the stages say so with their counts
  const double span = box.diagonal().norm();
  if (span < 1e-3) {
    char buf[160];
    std::snprintf(buf, sizeof buf,
                  "the %s's points span %.3g m (all in one place); no scene to "
                  "compare",
                  what, span);
    throw std::invalid_argument(buf);
  }
}

bool usableBounds(const Cloud& cloud, Eigen::Vector3d& lo, Eigen::Vector3d& hi) {
  lo.setConstant(std::numeric_limits<double>::infinity());
  hi = -lo;
  bool any = false;
  for (const auto& p : cloud) {
    if (!usablePoint(p)) continue;
    const Eigen::Vector3d v(p.x, p.y, p.z);
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
    any = true;
  }
  return any;
}

double shareInside(const Cloud& cloud, const Eigen::AlignedBox3d& extent, double margin_m) {
  if (extent.isEmpty()) return 0.0;
  const Eigen::AlignedBox3d grown(extent.min().array() - margin_m, extent.max().array() + margin_m);
  std::size_t usable = 0, inside = 0;
  for (const PointT& p : cloud) {
    if (!usablePoint(p)) continue;
    ++usable;
    inside += grown.contains(p.getVector3fMap().cast<double>());
  }
  return usable ? static_cast<double>(inside) / usable : 1.0;
}

double overlapDistance(const Eigen::AlignedBox3d& reference_extent, double floor_m) {
  const double diagonal = reference_extent.isEmpty() ? 0.0 : reference_extent.diagonal().norm();
  return std::max(floor_m, 0.01 * diagonal);
}

void requireOverlap(const Cloud& sweep, const Eigen::AlignedBox3d& reference_extent,
                    double overlap) {
  if (reference_extent.isEmpty()) return;
  const double margin = 0.1 * reference_extent.diagonal().norm();
  const double share = shareInside(sweep, reference_extent, margin);
  if (share < 0.25 || overlap < kMinOverlap) {
    char buf[400];
    std::snprintf(buf, sizeof buf,
                  "the sweep does not overlap the reference: overlap %.3f (%.1f %% of its "
                  "points within %.2f m of the map, %.1f %% within the map's extent grown by "
                  "%.2f m); check the frames and the sensor pose",
                  overlap, 100.0 * overlap, overlapDistance(reference_extent, 0.0), 100.0 * share,
                  margin);
    throw NoOverlapError(buf, overlap);
  }
}

void requireIndexInCloud(const Cloud& cloud, int index, const char* who) {
  if (index < 0 || index >= static_cast<int>(cloud.size())) {
    throw std::invalid_argument(std::string(who) + ": index " + std::to_string(index) +
                                " outside a cloud of " + std::to_string(cloud.size()) + " points");
  }
}

}  // namespace novelty_detection
