// The reference planes of the fine alignment (rules in alignment.h, step 1).
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>

#include "alignment/alignment_detail.h"

namespace novelty_detection {
namespace alignment_detail {

std::pair<double, std::size_t> cellOccupancy(const Points3d& points, double cell) {
  CellGrid g{cell};
  std::unordered_map<std::uint64_t, int> count;
  count.reserve(points.size());
  for (const auto& p : points) ++count[g.key(g.cellOf(p))];
  // Point-weighted: the occupancy of the cell a typical point lies in (a median over cells
  // would be set by the sparse far cells of a scanning sensor).
  std::vector<int> c;
  c.reserve(points.size());
  for (const auto& p : points) c.push_back(count[g.key(g.cellOf(p))]);
  if (c.empty()) return {0.0, 0};
  std::nth_element(c.begin(), c.begin() + c.size() / 2, c.end());
  return {static_cast<double>(c[c.size() / 2]), count.size()};
}

double diagonal(const Points3d& points) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const auto& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  return points.empty() ? 0.0 : (hi - lo).norm();
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}
}  // namespace alignment_detail

using alignment_detail::CellGrid;
using alignment_detail::cellOccupancy;
using alignment_detail::diagonal;
using alignment_detail::finite;
using alignment_detail::median;

AlignmentReference::AlignmentReference() : impl_(std::make_unique<Impl>()) {}
AlignmentReference::~AlignmentReference() = default;
AlignmentReference::AlignmentReference(AlignmentReference&&) noexcept = default;
AlignmentReference& AlignmentReference::operator=(AlignmentReference&&) noexcept = default;

bool AlignmentReference::empty() const { return impl_->planes.empty(); }
std::size_t AlignmentReference::planeCount() const { return impl_->planes.size(); }
double AlignmentReference::cellSize() const { return impl_->grid.cell; }
double AlignmentReference::noise() const { return impl_->noise_m; }

void AlignmentReference::build(const Cloud& cloud, const AlignmentParams& params,
                               const Indices& indices) {
  impl_ = std::make_unique<Impl>();
  Points3d points;
  auto add = [&](const PointT& p) {
    if (finite(p)) points.emplace_back(p.x, p.y, p.z);
  };
  if (indices.empty()) {
    for (const auto& p : cloud) add(p);
  } else {
    for (int i : indices) add(cloud[i]);
  }
  if (points.size() < 6) return;
  // Cell size from the data: start at 1/64 of the extent and rescale twice so that the
  // median occupied cell holds about plane_cell_points points (surfaces: count ~ cell^2).
  const double diag = diagonal(points);
  double cell = std::max(diag / 64.0, 1e-3);
  for (int pass = 0; pass < 2; ++pass) {
    const double occupancy = cellOccupancy(points, cell).first;
    if (occupancy <= 0.0) break;
    const double scale = std::sqrt(params.plane_cell_points / occupancy);
    cell *= std::clamp(scale, 0.25, 4.0);
  }
  cell = std::clamp(cell, 1e-3, std::max(diag, 1e-3));
  impl_->grid.cell = cell;

  // Points per cell, then a plane per planar cell.
  std::unordered_map<std::uint64_t, std::vector<int>> members;
  members.reserve(points.size() / 4 + 1);
  for (std::size_t i = 0; i < points.size(); ++i)
    members[CellGrid::key(impl_->grid.cellOf(points[i]))].push_back(static_cast<int>(i));

  // PCA of a point set: mean, eigenvalues (ascending), eigenvectors.
  struct Fit {
    Eigen::Vector3d mean;
    Eigen::Vector3d l;
    Eigen::Matrix3d v;
  };
  auto fit = [&points](const std::vector<int>& idx) {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (int i : idx) mean += points[i];
    mean /= static_cast<double>(idx.size());
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (int i : idx) cov += (points[i] - mean) * (points[i] - mean).transpose();
    cov /= static_cast<double>(idx.size());
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
    es.computeDirect(cov);
    return Fit{mean, es.eigenvalues(), es.eigenvectors()};
  };
  struct Candidate {
    std::uint64_t key;
    Eigen::Vector3i cell;
    Fit f;
  };
  std::vector<Candidate> candidates;
  std::vector<double> thickness;
  for (const auto& kv : members) {
    if (kv.second.size() < 6) continue;
    const Fit f = fit(kv.second);
    // Planar: thin across (l0 < planarity * l1; not a corner) and spread along two
    // directions (l1 >= planarity * l2). The second test matters on scanning lasers: the
    // points of one scan line crossing a cell are coplanar with the *scan plane* (range
    // noise acts along the beams, inside that plane), so l0 ~ 0 with a normal that is not
    // the surface's.
    const Eigen::Vector3d& l = f.l;
    if (!(l(1) > 0.0) || !(l(0) < params.planarity * l(1)) || !(l(1) >= params.planarity * l(2)))
      continue;
    candidates.push_back({kv.first, impl_->grid.cellOf(f.mean), f});
    thickness.push_back(std::sqrt(std::max(l(0), 0.0)));
  }
  double noise = median(thickness);
  // Refit each plane on a slab around it, gathered from the neighbouring cells: the points of
  // one cell are cut by its faces, and when a surface runs close to a face only the points
  // whose noise pushed them inside remain, which moves the centroid off the surface by up to
  // the noise (measured: centimetre pose bias). Twice, with the noise re-estimated.
  for (int pass = 0; pass < 2; ++pass) {
    thickness.clear();
    const double slab = 3.0 * noise;
    const double reach = 0.5 * cell;
    std::vector<int> idx;
    for (Candidate& c : candidates) {
      const Eigen::Vector3d n = c.f.v.col(0);
      idx.clear();
      for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dz = -1; dz <= 1; ++dz) {
            const auto it = members.find(CellGrid::key(c.cell + Eigen::Vector3i(dx, dy, dz)));
            if (it == members.end()) continue;
            for (int i : it->second) {
              const Eigen::Vector3d d = points[i] - c.f.mean;
              const double r = n.dot(d);
              if (std::abs(r) <= slab && (d - r * n).norm() <= reach) idx.push_back(i);
            }
          }
      if (idx.size() >= 6) c.f = fit(idx);
      thickness.push_back(std::sqrt(std::max(c.f.l(0), 0.0)));
    }
    noise = median(thickness);
  }
  for (const Candidate& c : candidates) {
    const Eigen::Vector3d& l = c.f.l;
    if (!(l(0) < params.planarity * l(1))) continue;
    impl_->plane_of_cell[c.key] = static_cast<int>(impl_->planes.size());
    impl_->planes.push_back({c.f.mean, c.f.v.col(0).normalized()});
  }
  impl_->noise_m = noise;
}

}  // namespace novelty_detection
