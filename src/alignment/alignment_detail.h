// Shared by the two halves of the fine alignment (alignment_reference.cpp builds the planes,
// alignment.cpp matches the sweep to them). Not installed.
#pragma once

#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

#include "novelty_detection/alignment/alignment.h"

namespace novelty_detection {
namespace alignment_detail {

inline bool finite(const PointT& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
}

/// Integer cell of a point; 21 bits per axis packed in one key (cells within +-2^20 of the
/// origin, i.e. +-1000 km at 1 m cells: no collisions in practice).
struct CellGrid {
  double cell = 1.0;
  Eigen::Vector3i cellOf(const Eigen::Vector3d& p) const {
    // Clamped into the key's range (and away from int overflow, undefined behaviour): cells
    // of points beyond it share border keys, and the distance tests then reject them.
    auto c = [this](double v) {
      return static_cast<int>(std::clamp(std::floor(v / cell), -kMaxCell, kMaxCell));
    };
    return Eigen::Vector3i(c(p.x()), c(p.y()), c(p.z()));
  }
  static constexpr double kMaxCell = (1 << 20) - 2;
  static std::uint64_t key(const Eigen::Vector3i& c) {
    auto b = [](int v) { return static_cast<std::uint64_t>(v + (1 << 20)) & 0x1FFFFFu; };
    return (b(c.x()) << 42) | (b(c.y()) << 21) | b(c.z());
  }
};

/// Median occupancy of the cells of size `cell` over `points` (point-weighted: the occupancy
/// of the cell a typical point lies in), and the number of cells.
std::pair<double, std::size_t> cellOccupancy(const Points3d& points, double cell);

/// Length of the diagonal of the bounding box of `points` (0 when empty).
double diagonal(const Points3d& points);

/// Upper median (0 when empty).
double median(std::vector<double> v);

}  // namespace alignment_detail

struct AlignmentReference::Impl {
  struct Plane {
    Eigen::Vector3d centroid;
    Eigen::Vector3d normal;
  };
  alignment_detail::CellGrid grid;
  std::unordered_map<std::uint64_t, int> plane_of_cell;
  std::vector<Plane> planes;
  double noise_m = 0.0;  ///< median RMS thickness of the planes: the map's point noise
};

}  // namespace novelty_detection
