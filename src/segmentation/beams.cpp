// The sweep's beams against a box (ROS-free): which returns' beams end in it, pass it, or end
// in front of it. The segmentation's tests of the gap between two pieces (novelty_segmentation.h).
#include "novelty_detection/segmentation/novelty_segmentation.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace novelty_detection {

namespace {

/// Where the beam origin + t (p - origin), t >= 0, is in the box [lo, hi]: [t0, t1], empty
/// (t0 > t1) when it misses the box.
std::pair<float, float> beamInBox(const Eigen::Vector3f& origin, const Eigen::Vector3f& p,
                                  const Eigen::Vector3f& lo, const Eigen::Vector3f& hi) {
  const Eigen::Vector3f d = p - origin;
  float t0 = 0.f, t1 = std::numeric_limits<float>::infinity();
  for (int k = 0; k < 3 && t0 <= t1; ++k) {
    if (std::abs(d[k]) < 1e-9f) {
      if (origin[k] < lo[k] || origin[k] > hi[k]) return {1.f, 0.f};  // parallel, outside
      continue;
    }
    float a = (lo[k] - origin[k]) / d[k], b = (hi[k] - origin[k]) / d[k];
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
  }
  return {t0, t1};
}

}  // namespace

std::size_t beamsThroughBox(const Cloud& cloud, const Indices& kept,
                            const std::vector<char>& novel_mask, const Eigen::Vector3f& origin,
                            const Eigen::Vector3f& lo, const Eigen::Vector3f& hi,
                            std::size_t enough) {
  std::size_t count = 0;
  for (int i : kept) {
    if (novel_mask[i]) continue;
    // The segment origin -> p, t in [0, 1], against the box.
    const auto [t0, t1] = beamInBox(origin, cloud[i].getVector3fMap(), lo, hi);
    if (t0 <= std::min(t1, 1.f) && ++count >= enough) break;
  }
  return count;
}

namespace {

/// Finite returns of the whole cloud not in `skip` whose beam from `origin` (continued)
/// meets the box where `where(t0, t1)` holds (the return at t = 1), up to `enough`.
template <class Where>
std::size_t countBeams(const Cloud& cloud, const std::vector<char>& skip,
                       const Eigen::Vector3f& origin, const Eigen::Vector3f& lo,
                       const Eigen::Vector3f& hi, std::size_t enough, Where where) {
  std::size_t count = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f p = cloud[i].getVector3fMap();
    if (skip[i] || !p.allFinite()) continue;
    const auto [t0, t1] = beamInBox(origin, p, lo, hi);
    if (t0 <= t1 && where(t0, t1) && ++count >= enough) break;
  }
  return count;
}

}  // namespace

std::size_t beamsPastBox(const Cloud& cloud, const std::vector<char>& novel_mask,
                         const Eigen::Vector3f& origin, const Eigen::Vector3f& lo,
                         const Eigen::Vector3f& hi, std::size_t enough) {
  return countBeams(cloud, novel_mask, origin, lo, hi, enough,
                    [](float, float t1) { return t1 < 1.f; });  // the box before the return
}

std::size_t beamsBeforeBox(const Cloud& cloud, const std::vector<char>& skip,
                           const Eigen::Vector3f& origin, const Eigen::Vector3f& lo,
                           const Eigen::Vector3f& hi, std::size_t enough) {
  return countBeams(cloud, skip, origin, lo, hi, enough,
                    [](float t0, float) { return t0 > 1.f; });  // the box beyond the return
}

}  // namespace novelty_detection
