// Robust, bounded point-to-plane ICP of the current sweep on the reference planes (the rules
// are in alignment.h).
#include "novelty_detection/alignment/alignment.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>
#include <unordered_map>
#include <vector>

#include "alignment/alignment_detail.h"

namespace novelty_detection {
namespace {

using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;
using alignment_detail::CellGrid;
using alignment_detail::cellOccupancy;
using alignment_detail::diagonal;
using alignment_detail::finite;
using alignment_detail::median;

double tukey(double r, double c) {
  const double u = r / c;
  return std::abs(u) >= 1.0 ? 0.0 : (1.0 - u * u) * (1.0 - u * u);
}

/// Tukey's loss for that weight, scaled to 1 at and beyond the cut-off c.
double tukeyRho(double r, double c) {
  const double u = r / c;
  if (std::abs(u) >= 1.0) return 1.0;
  const double v = 1.0 - u * u;
  return 1.0 - v * v * v;
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
  // The planes about each sample's cell: its own cell's, then its 26 neighbours' in a fixed
  // order, looked up once while the sample stays in that cell (the corrections move samples
  // by centimetres, the cells span decimetres).
  struct PlanesNear {
    Eigen::Vector3i cell;
    bool known = false, around_known = false;
    int own = -1;
    std::vector<int> around;
  };
  std::vector<PlanesNear> near(samples.size());
  const auto planeIn = [&ref](const Eigen::Vector3i& cc) {
    const auto it = ref.plane_of_cell.find(CellGrid::key(cc));
    return it == ref.plane_of_cell.end() ? -1 : it->second;
  };
  // Matches every sample to a plane within `limit` of it (see `consider`), its projection
  // within one cell of that plane's centroid.
  auto correspond = [&](double limit) {
    matches.clear();
    const double reach2 = ref.grid.cell * ref.grid.cell;
    for (std::size_t i = 0; i < samples.size(); ++i) {
      const Eigen::Vector3d p = T * samples[i];
      const Eigen::Vector3i c = ref.grid.cellOf(p);
      PlanesNear& nb = near[i];
      if (!nb.known || nb.cell != c) {
        nb.known = true;
        nb.around_known = false;
        nb.cell = c;
        nb.own = planeIn(c);
      }
      int best = -1;
      double best_d2 = std::numeric_limits<double>::infinity();
      // The plane of the sample's own cell, else of the neighbouring cell whose centroid is
      // nearest (not the smallest |r|: that would pick whichever noisy plane agrees best and
      // bias the pose towards the noise).
      auto consider = [&](int plane) {
        const auto& pl = ref.planes[plane];
        const Eigen::Vector3d d = p - pl.centroid;
        const double r = pl.normal.dot(d);
        const double d2 = d.squaredNorm();
        if (std::abs(r) > limit || (d - r * pl.normal).squaredNorm() > reach2 || d2 >= best_d2)
          return;
        best_d2 = d2;
        best = plane;
      };
      if (nb.own >= 0) consider(nb.own);
      if (best < 0) {
        if (!nb.around_known) {
          nb.around_known = true;
          nb.around.clear();
          for (int dx = -1; dx <= 1; ++dx)
            for (int dy = -1; dy <= 1; ++dy)
              for (int dz = -1; dz <= 1; ++dz)
                if (dx || dy || dz) {
                  const int plane = planeIn(c + Eigen::Vector3i(dx, dy, dz));
                  if (plane >= 0) nb.around.push_back(plane);
                }
        }
        for (const int plane : nb.around) consider(plane);
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

  // Fitness at the final pose, with the last cut-off, and the robust cost there and at the
  // given pose (the same gate and cut-off): what the correction gains.
  double weight_sum = 0.0;
  for (const double w : sample_weight) weight_sum += w;
  const auto cost = [&] {
    double c = weight_sum;  // a sample matched to no plane costs 1
    for (const auto& m : matches) c += sample_weight[m.sample] * (tukeyRho(m.r, cut) - 1.0);
    return c;
  };
  const Eigen::Isometry3d solved = T;
  T = Eigen::Isometry3d::Identity();
  correspond(gate);
  const double cost_given = cost();
  T = solved;
  correspond(gate);
  const double cost_solved = cost();
  out.cost_reduction = cost_given > 0.0 ? (cost_given - cost_solved) / cost_given : 0.0;
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
  } else if (out.cost_reduction < params_.min_cost_reduction) {
    why << "the correction lowers the cost by " << out.cost_reduction
        << ", below min_cost_reduction " << params_.min_cost_reduction;
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
  // An unknown origin (zero, not stated) stays unknown; a known one moves, w kept.
  if (sensorOriginKnown(cloud.sensor_origin_))
    out.sensor_origin_.head<3>() = R * cloud.sensor_origin_.head<3>() + t;
  out.sensor_orientation_ = Eigen::Quaternionf(R) * cloud.sensor_orientation_;
  return out;
}

}  // namespace novelty_detection
