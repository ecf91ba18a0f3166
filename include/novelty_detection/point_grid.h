// A hash grid over a point list for fixed-radius neighbour queries, and the median point
// spacing that sizes it. Header-only, ROS-free.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <unordered_map>
#include <vector>

#include "novelty_detection/types.h"

namespace novelty_detection {

/// Median distance of a few evenly spread points to their nearest other point.
inline double medianSpacing(const Points3d& points) {
  const std::size_t n = points.size();
  if (n < 2) return 0.0;
  const std::size_t samples = std::min<std::size_t>(n, 64);
  std::vector<double> nn;
  nn.reserve(samples);
  for (std::size_t k = 0; k < samples; ++k) {
    const std::size_t i = k * n / samples;
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t j = 0; j < n; ++j) {
      if (j == i) continue;
      const double d2 = (points[j] - points[i]).squaredNorm();
      if (d2 > 0.0 && d2 < best) best = d2;
    }
    if (std::isfinite(best)) nn.push_back(std::sqrt(best));
  }
  if (nn.empty()) return 0.0;
  std::nth_element(nn.begin(), nn.begin() + nn.size() / 2, nn.end());
  return nn[nn.size() / 2];
}

/// Hash grid of points in cubic cells of a given size (keeps a reference: the points must
/// outlive the grid).
class PointGrid {
 public:
  /// Throws std::invalid_argument unless cell > 0.
  PointGrid(const Points3d& points, double cell) : points_(points), cell_(cell) {
    if (!(cell > 0.0) || !std::isfinite(cell)) {
      throw std::invalid_argument("PointGrid: cell size must be positive and finite");
    }
    grid_.reserve(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
      grid_[key(cellOf(points[i]))].push_back(static_cast<int>(i));
    }
  }

  /// Index of the nearest point within one cell size of p, or -1.
  int nearest(const Eigen::Vector3d& p) const {
    int best = -1;
    double best_d2 = std::numeric_limits<double>::infinity();
    forNeighbours(p, cell_, [&](int j) {
      const double d2 = (points_[static_cast<std::size_t>(j)] - p).squaredNorm();
      if (d2 < best_d2) {
        best_d2 = d2;
        best = j;
      }
    });
    return best;
  }

  /// Calls f(j) for every point j within `radius` (<= cell size) of p.
  template <class F>
  void forNeighbours(const Eigen::Vector3d& p, double radius, F&& f) const {
    const Eigen::Vector3i c = cellOf(p);
    const double r2 = radius * radius;
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it = grid_.find(key(c + Eigen::Vector3i(dx, dy, dz)));
          if (it == grid_.end()) continue;
          for (int j : it->second) {
            if ((points_[static_cast<std::size_t>(j)] - p).squaredNorm() <= r2) f(j);
          }
        }
      }
    }
  }

 private:
  Eigen::Vector3i cellOf(const Eigen::Vector3d& p) const {
    return Eigen::Vector3i(static_cast<int>(std::floor(p.x() / cell_)),
                           static_cast<int>(std::floor(p.y() / cell_)),
                           static_cast<int>(std::floor(p.z() / cell_)));
  }
  static std::uint64_t key(const Eigen::Vector3i& c) {
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(c.x())) * 73856093ULL) ^
           (static_cast<std::uint64_t>(static_cast<std::uint32_t>(c.y())) * 19349663ULL) ^
           (static_cast<std::uint64_t>(static_cast<std::uint32_t>(c.z())) * 83492791ULL);
  }

  const Points3d& points_;
  double cell_;
  std::unordered_map<std::uint64_t, std::vector<int>> grid_;
};

}  // namespace novelty_detection
