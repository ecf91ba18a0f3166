// Robust, bounded point-to-plane ICP of the current sweep on the reference planes (the rules
// are in alignment.h).
#include "novelty_detection/alignment.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>
#include <unordered_map>
#include <vector>

namespace novelty_detection {
namespace {

using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;

bool finite(const PointT& p) {
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

/// Median occupancy of the cells of size `cell` over `points`, and the number of cells.
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

double tukey(double r, double c) {
  const double u = r / c;
  return std::abs(u) >= 1.0 ? 0.0 : (1.0 - u * u) * (1.0 - u * u);
}

Eigen::Isometry3d increment(const Vec6& d, const Eigen::Vector3d& centre) {
  // p -> R(omega) (p - centre) + centre + v: the rotation acts about the sample centroid, so
  // rotation and translation are nearly decoupled in the normal equations.
  const Eigen::Vector3d w = d.head<3>();
  const double angle = w.norm();
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  if (angle > 0.0) R = Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = centre - R * centre + d.tail<3>();
  return T;
}

}  // namespace

struct AlignmentReference::Impl {
  struct Plane {
    Eigen::Vector3d centroid;
    Eigen::Vector3d normal;
  };
  CellGrid grid;
  std::unordered_map<std::uint64_t, int> plane_of_cell;
  std::vector<Plane> planes;
  double noise_m = 0.0;  ///< median RMS thickness of the planes: the map's point noise
};

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

FineAligner::FineAligner(const AlignmentParams& params) : params_(params) { params_.validate(); }

AlignmentResult FineAligner::estimate(const AlignmentReference& reference,
                                      const Cloud& current) const {
  const auto start = std::chrono::steady_clock::now();
  AlignmentResult out;
  out.attempted = true;
  auto finish = [&](const std::string& reason) {
    if (!reason.empty()) {
      out.applied = false;
      out.status = "rejected: " + reason;
    }
    out.ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    return out;
  };
  const AlignmentReference::Impl& ref = *reference.impl_;
  if (ref.planes.empty()) return finish("the reference has no planar structure");

  // Sample: every k-th point in input order, so that which points are kept does not depend
  // on their noise (voxel centroids do: a voxel face cuts the noise distribution of a surface
  // running near it, which biased the pose by millimetres to centimetres). Each sample is
  // weighted by 1 / (samples in its voxel), voxels sized from the data to about
  // sample_points occupied ones, so near, dense parts do not dominate the rotation.
  Points3d points;
  points.reserve(current.size());
  for (const auto& p : current)
    if (finite(p)) points.emplace_back(p.x, p.y, p.z);
  if (points.size() < static_cast<std::size_t>(params_.min_correspondences))
    return finish("too few points (" + std::to_string(points.size()) + ")");
  const std::size_t stride = std::max<std::size_t>(1, points.size() / params_.sample_points);
  Points3d samples;
  for (std::size_t i = 0; i < points.size(); i += stride) samples.push_back(points[i]);
  std::vector<double> sample_weight(samples.size(), 1.0);
  {
    const double diag = diagonal(samples);
    double voxel = std::max(diag / 128.0, 1e-4);
    const std::size_t occupied = cellOccupancy(samples, voxel).second;
    voxel *=
        std::clamp(std::sqrt(static_cast<double>(occupied) / params_.sample_points), 0.1, 10.0);
    CellGrid g{voxel};
    std::unordered_map<std::uint64_t, int> count;
    count.reserve(samples.size());
    std::vector<std::uint64_t> keys(samples.size());
    for (std::size_t i = 0; i < samples.size(); ++i) ++count[keys[i] = g.key(g.cellOf(samples[i]))];
    for (std::size_t i = 0; i < samples.size(); ++i) sample_weight[i] = 1.0 / count[keys[i]];
  }
  out.samples = static_cast<int>(samples.size());

  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : samples) centroid += p;
  centroid /= static_cast<double>(samples.size());
  double radius2 = 0.0;
  for (const auto& p : samples) radius2 += (p - centroid).squaredNorm();
  const double radius = std::max(std::sqrt(radius2 / samples.size()), 1e-3);
  const Eigen::Vector3f o = current.sensor_origin_.head<3>();
  const Eigen::Vector3d origin = o.isZero() ? centroid : Eigen::Vector3d(o.cast<double>());

  const double max_rot = params_.max_rotation_deg * M_PI / 180.0;
  // The gate starts at twice the bound (plus a cell), so that an error somewhat beyond the
  // bound is still found, and then reported as beyond it, rather than half corrected.
  double gate = 2.0 * (params_.max_translation_m + max_rot * radius) + ref.grid.cell * 0.5;
  const double conv_rot = params_.convergence_rotation_deg * M_PI / 180.0;

  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  struct Match {
    int sample;
    double r;
    Eigen::Vector3d n;
  };
  std::vector<Match> matches;
  matches.reserve(samples.size());
  // Matches every sample to a plane within `limit` of it (see `consider`), its projection
  // within one cell of that plane's centroid.
  auto correspond = [&](double limit) {
    matches.clear();
    const double reach2 = ref.grid.cell * ref.grid.cell;
    for (std::size_t i = 0; i < samples.size(); ++i) {
      const Eigen::Vector3d p = T * samples[i];
      const Eigen::Vector3i c = ref.grid.cellOf(p);
      int best = -1;
      double best_d2 = std::numeric_limits<double>::infinity();
      // The plane of the sample's own cell, else of the neighbouring cell whose centroid is
      // nearest (not the smallest |r|: that would pick whichever noisy plane agrees best and
      // bias the pose towards the noise).
      auto consider = [&](const Eigen::Vector3i& cc) {
        const auto it = ref.plane_of_cell.find(CellGrid::key(cc));
        if (it == ref.plane_of_cell.end()) return;
        const auto& pl = ref.planes[it->second];
        const Eigen::Vector3d d = p - pl.centroid;
        const double r = pl.normal.dot(d);
        const double d2 = d.squaredNorm();
        if (std::abs(r) > limit || (d - r * pl.normal).squaredNorm() > reach2 || d2 >= best_d2)
          return;
        best_d2 = d2;
        best = it->second;
      };
      consider(c);
      if (best < 0) {
        for (int dx = -1; dx <= 1; ++dx)
          for (int dy = -1; dy <= 1; ++dy)
            for (int dz = -1; dz <= 1; ++dz)
              if (dx || dy || dz) consider(c + Eigen::Vector3i(dx, dy, dz));
      }
      if (best >= 0) {
        const auto& pl = ref.planes[best];
        matches.push_back({static_cast<int>(i), pl.normal.dot(p - pl.centroid), pl.normal});
      }
    }
  };
  // Tukey cut-off from the map's noise, fixed: a scale re-estimated from the gated residuals
  // shrinks with the gate and collapses (measured).
  // The noise is floored at 0.5 % of the plane cell for noise-free data.
  const double cut = params_.robust_scale_factor * std::max(ref.noise_m, 0.005 * ref.grid.cell);
  int degenerate = 0;
  for (int it = 0; it < params_.max_iterations; ++it) {
    out.iterations = it + 1;
    correspond(gate);
    if (matches.size() < static_cast<std::size_t>(params_.min_correspondences)) {
      return finish("too few correspondences (" + std::to_string(matches.size()) + ")");
    }
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (const auto& m : matches) c += T * samples[m.sample];
    c /= static_cast<double>(matches.size());
    // Tukey cut-off: robust_scale_factor robust sigmas (1.4826 MAD) of the current residuals,
    // within [noise cut-off, gate]: broad while the sweep is far off, the map's noise at the
    // end. The floor keeps the scale from collapsing with the gate (measured without it).
    std::vector<double> abs_r(matches.size());
    for (std::size_t k = 0; k < matches.size(); ++k) abs_r[k] = std::abs(matches[k].r);
    const double scale = std::clamp(params_.robust_scale_factor * 1.4826 * median(std::move(abs_r)),
                                    cut, std::max(cut, gate));
    Mat6 H = Mat6::Zero();
    Vec6 g = Vec6::Zero();
    for (const auto& m : matches) {
      const double w = sample_weight[m.sample] * tukey(m.r, scale);
      if (w <= 0.0) continue;
      Vec6 J;
      // Rotation columns scaled by the sample radius (so eigenvalues compare in metres).
      J.head<3>() = (T * samples[m.sample] - c).cross(m.n) / radius;
      J.tail<3>() = m.n;
      H.selfadjointView<Eigen::Upper>().rankUpdate(J, w);
      g -= w * m.r * J;
    }
    H = H.selfadjointView<Eigen::Upper>();
    const Eigen::SelfAdjointEigenSolver<Mat6> es(H);
    const Vec6 lambda = es.eigenvalues();
    const double lmax = lambda(5);
    if (!(lmax > 0.0)) return finish("no inlier correspondences");
    // Update only in the well-constrained subspace (solution remapping): the pose stays as
    // given along directions the structure does not constrain.
    Vec6 step = Vec6::Zero();
    degenerate = 0;
    for (int k = 0; k < 6; ++k) {
      if (lambda(k) < params_.degeneracy_ratio * lmax) {
        ++degenerate;
        continue;
      }
      const Vec6 v = es.eigenvectors().col(k);
      step += v * (v.dot(g) / lambda(k));
    }
    step.head<3>() /= radius;
    T = increment(step, c) * T;
    const double moved = (T * origin - origin).norm();
    const double turned = Eigen::AngleAxisd(T.rotation()).angle();
    if (!std::isfinite(moved) || !std::isfinite(turned)) return finish("diverged (non-finite)");
    // Far beyond the bound: stop early, it is rejected below anyway.
    if (moved > 2.0 * params_.max_translation_m + 0.05 || turned > 2.0 * max_rot + 0.02) break;
    const bool gate_settled = gate <= cut;
    // Shrink the gate once the step is small against it (else the sweep is still moving and
    // a shrunk gate would cut its true correspondences: a half-done correction).
    const double step_m = step.tail<3>().norm() + step.head<3>().norm() * radius;
    if (step_m < 0.25 * gate) gate = std::max(gate * params_.gate_shrink, cut);
    if (gate_settled && step.tail<3>().norm() < params_.convergence_translation_m &&
        step.head<3>().norm() < conv_rot) {
      break;
    }
  }

  // Fitness at the final pose, with the last cut-off.
  correspond(gate);
  double sum2 = 0.0;
  int inliers = 0;
  for (const auto& m : matches) {
    if (std::abs(m.r) >= cut) continue;
    sum2 += m.r * m.r;
    ++inliers;
  }
  out.fitness_m = inliers ? std::sqrt(sum2 / inliers) : 0.0;
  out.inlier_fraction = static_cast<double>(inliers) / static_cast<double>(samples.size());
  out.degenerate_directions = degenerate;
  out.correction = T;
  out.translation_m = (T * origin - origin).norm();
  out.rotation_deg = Eigen::AngleAxisd(T.rotation()).angle() * 180.0 / M_PI;

  std::ostringstream why;
  if (degenerate == 6) {
    why << "no pose direction is constrained by the structure";
  } else if (out.translation_m > params_.max_translation_m) {
    why << "translation " << out.translation_m << " m exceeds max_translation_m "
        << params_.max_translation_m;
  } else if (out.rotation_deg > params_.max_rotation_deg) {
    why << "rotation " << out.rotation_deg << " deg exceeds max_rotation_deg "
        << params_.max_rotation_deg;
  } else if (inliers < params_.min_correspondences) {
    why << "too few inliers (" << inliers << ")";
  } else if (out.inlier_fraction < params_.min_inlier_fraction) {
    why << "inlier fraction " << out.inlier_fraction << " below min_inlier_fraction "
        << params_.min_inlier_fraction;
  }
  if (!why.str().empty()) return finish(why.str());
  out.applied = true;
  out.status = "applied";
  if (degenerate > 0)
    out.status += " (" + std::to_string(degenerate) + " unconstrained directions left unchanged)";
  return finish("");
}

Cloud transformCloud(const Cloud& cloud, const Eigen::Isometry3d& T) {
  Cloud out = cloud;
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  for (auto& p : out.points) {
    if (!finite(p)) continue;
    p.getVector3fMap() = R * p.getVector3fMap() + t;
  }
  // A zero origin means "unknown" in this package (PCD without VIEWPOINT): keep it unknown.
  if (!cloud.sensor_origin_.head<3>().isZero())
    out.sensor_origin_.head<3>() = R * cloud.sensor_origin_.head<3>() + t;
  out.sensor_orientation_ = Eigen::Quaternionf(R) * cloud.sensor_orientation_;
  return out;
}

}  // namespace novelty_detection
