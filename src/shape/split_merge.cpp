#include "novelty_detection/shape/split_merge.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <stdexcept>
#include <unordered_map>
#include <utility>

#include <Eigen/Eigenvalues>

#include "common/parallel.h"
#include "novelty_detection/point_grid.h"
#include "novelty_detection/shape/superquadric.h"
#include "shape/point_subsets.h"

namespace novelty_detection {
namespace {

using detail::gather;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kMeanAbsGaussian = 0.7978845608028654;  // E|x| / sigma = sqrt(2 / pi)
constexpr double kMaxLagFraction = 0.1;  // residual noise: median lag <= this x part diagonal

/// Local scale of the sampling and the sensor noise, from a few evenly spread points: the
/// smallest neighbourhood (k nearest, k >= 12, grown by half until it is two-dimensional,
/// lambda1 >= 0.1 lambda2, so that scan lines sparser than the points along them are
/// bridged) gives its radius and the RMS distance of its points to their best plane,
/// sqrt(lambda0). Medians over the samples; edges and corners are a minority.
void neighbourhoodScale(const Points3d& points, double* radius, double* noise) {
  *radius = 0.0;
  *noise = 0.0;
  const std::size_t n = points.size();
  if (n < 4) return;
  const std::size_t samples = std::min<std::size_t>(n, 48);
  std::vector<double> radii, rms;
  std::vector<std::pair<double, int>> dist(n);
  for (std::size_t s = 0; s < samples; ++s) {
    const Eigen::Vector3d& p = points[s * n / samples];
    for (std::size_t j = 0; j < n; ++j) {
      dist[j] = {(points[j] - p).squaredNorm(), static_cast<int>(j)};
    }
    const std::size_t k_max = std::min<std::size_t>(n, 400);
    // dist[0, sorted) holds the nearest in order (as a partial sort would; distinct indices
    // make the order unique), extended only as far as the neighbourhood grows.
    std::size_t sorted = 0;
    for (std::size_t k = std::min<std::size_t>(12, k_max);; k = std::min(k_max, k + k / 2)) {
      if (k > sorted) {
        std::nth_element(dist.begin() + sorted, dist.begin() + (k - 1), dist.end());
        std::sort(dist.begin() + sorted, dist.begin() + k);
        sorted = k;
      }
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (std::size_t m = 0; m < k; ++m) mean += points[static_cast<std::size_t>(dist[m].second)];
      mean /= static_cast<double>(k);
      Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
      for (std::size_t m = 0; m < k; ++m) {
        const Eigen::Vector3d d = points[static_cast<std::size_t>(dist[m].second)] - mean;
        cov.noalias() += d * d.transpose();
      }
      cov /= static_cast<double>(k);
      const Eigen::Vector3d l =
          Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov, Eigen::EigenvaluesOnly)
              .eigenvalues()
              .cwiseMax(0.0);
      if (l[1] >= 0.1 * l[2] || k == k_max) {
        radii.push_back(std::sqrt(dist[k - 1].first));
        rms.push_back(std::sqrt(l[0]));
        break;
      }
    }
  }
  auto median = [](std::vector<double>& v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  *radius = median(radii);
  *noise = median(rms);
}

/// Sensor noise normal to the surface, from a part's residuals (the nugget of their
/// variogram): a signed distance d_i to the part's model is systematic error, smooth along
/// the surface, plus noise, independent from point to point. The difference to the nearest
/// other point of the part cancels the first and doubles the variance of the second, so
/// sigma^2 = median((d_i - d_j)^2) / (2 * 0.4549), 0.4549 being the median of chi^2(1).
/// "Nearest" is measured along the model's tangent plane among the few nearest in 3D: in
/// 3D alone, a point pushed outward by noise is nearest to others pushed outward, which
/// would hide the noise. Unlike a local
/// plane's RMS it sees the range noise of a scanning sensor, whose scan lines are each
/// exactly planar whatever their noise. 0 when no point has a neighbour within `radius`, or
/// when the median neighbour distance exceeds kMaxLagFraction of the part's bounding-box
/// diagonal (sparse scans: the differences would carry model error too).
double residualNoise(const Points3d& points, const Indices& part, const std::vector<int>& owner,
                     const Superquadric& model, const PointGrid& grid, double radius) {
  const std::size_t n = part.size();
  if (n < 2) return 0.0;
  const int id = owner[static_cast<std::size_t>(part.front())];
  const std::size_t samples = std::min<std::size_t>(n, 256);
  const SurfaceQuery surface(model);
  // Candidates: the few nearest in 3D (the same sheet of surface, not a neighbouring part
  // behind it); of these, the nearest along the tangent plane.
  constexpr std::size_t kCandidates = 6;
  std::vector<std::pair<double, int>> near;
  std::vector<double> sq_diff, lag;
  sq_diff.reserve(samples);
  for (std::size_t s = 0; s < samples; ++s) {
    const Eigen::Vector3d& p = points[static_cast<std::size_t>(part[s * n / samples])];
    Eigen::Vector3d normal;
    const double signed_p = surface.signedDistance(p, &normal);
    near.clear();
    grid.forNeighbours(p, radius, [&](int j) {
      if (owner[static_cast<std::size_t>(j)] != id) return;
      const double d2 = (points[static_cast<std::size_t>(j)] - p).squaredNorm();
      if (d2 > 0.0) near.emplace_back(d2, j);
    });
    if (near.empty()) continue;
    const std::size_t k = std::min<std::size_t>(near.size(), kCandidates);
    std::partial_sort(near.begin(), near.begin() + k, near.end());
    int nearest = -1;
    double best = kInf;
    for (std::size_t m = 0; m < k; ++m) {
      const Eigen::Vector3d delta = points[static_cast<std::size_t>(near[m].second)] - p;
      const double along = delta.dot(normal);
      const double tangential = near[m].first - along * along;
      if (tangential < best) {
        best = tangential;
        nearest = near[m].second;
      }
    }
    const double diff =
        signed_p - surface.signedDistance(points[static_cast<std::size_t>(nearest)]);
    if (std::isfinite(diff)) {
      sq_diff.push_back(diff * diff);
      lag.push_back((points[static_cast<std::size_t>(nearest)] - p).norm());
    }
  }
  if (sq_diff.empty()) return 0.0;
  // The nugget needs lags far shorter than the scale of the model's error, the part's size:
  // on sparse scans neighbours are far apart and their differences carry model error too.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(kInf), hi = -lo;
  for (int i : part) {
    lo = lo.cwiseMin(points[static_cast<std::size_t>(i)]);
    hi = hi.cwiseMax(points[static_cast<std::size_t>(i)]);
  }
  std::nth_element(lag.begin(), lag.begin() + lag.size() / 2, lag.end());
  if (lag[lag.size() / 2] > kMaxLagFraction * (hi - lo).norm()) return 0.0;
  std::nth_element(sq_diff.begin(), sq_diff.begin() + sq_diff.size() / 2, sq_diff.end());
  return std::sqrt(sq_diff[sq_diff.size() / 2] / (2.0 * 0.4549));
}

/// Marks leaves whose points come closer than `radius`.
void touchingLeaves(const Points3d& points, const PointGrid& grid, const std::vector<int>& label,
                    double radius, std::vector<std::vector<char>>& adjacent) {
  for (std::size_t i = 0; i < points.size(); ++i) {
    const int li = label[i];
    grid.forNeighbours(points[i], radius, [&](int j) {
      const int lj = label[static_cast<std::size_t>(j)];
      if (li != lj) adjacent[li][lj] = adjacent[lj][li] = 1;
    });
  }
}

}  // namespace

SplitMerge::SplitMerge(const SuperquadricParams& params) : params_(params), fitter_(params) {}

int SplitMerge::innerIterations() const {
  // Fits inside split and merge only rank candidates: fewer LM iterations suffice.
  return std::min(params_.max_iterations, params_.split_iterations);
}

FitResult SplitMerge::refitPart(const Points3d& points, const Indices& indices,
                                const Superquadric& start) const {
  return fitter_.refine(subsample(gather(points, indices), params_.split_fit_points), start,
                        innerIterations(), false, FitMeasures::kSurface);
}

void SplitMerge::completeMeasures(const Points3d& points,
                                  std::vector<SuperquadricPart>& parts) const {
  // The ranking fits measured mean_distance only; the parts returned report every measure
  // over the points they were fitted on (the same subsample as refitPart()'s).
  detail::parallelFor(static_cast<int>(parts.size()), threads_, [&](int k) {
    FitResult& fit = parts[static_cast<std::size_t>(k)].fit;
    const Points3d fitted = subsample(gather(points, parts[static_cast<std::size_t>(k)].indices),
                                      params_.split_fit_points);
    fit.mean_radial_distance = meanRadialDistance(fit.sq, fitted);
    fit.residual = meanSquaredResidual(fit.sq, fitted);
    fit.sq.residual = fit.residual;
  });
}

double SplitMerge::exactForNoise(double noise) const {
  return (1.0 + params_.merge_tolerance) * kMeanAbsGaussian * noise;
}

struct SplitMerge::Scale {
  double radius = 0.0;              ///< neighbourhood radius times neighbour_distance_factor [m]
  double plane_noise = 0.0;         ///< local plane RMS [m]
  std::unique_ptr<PointGrid> grid;  ///< at `radius`; none when it is 0
};

SplitMerge::Scale SplitMerge::scaleOf(const Points3d& points) const {
  Scale scale;
  neighbourhoodScale(points, &scale.radius, &scale.plane_noise);
  scale.radius *= params_.neighbour_distance_factor;
  if (scale.radius > 0.0 && std::isfinite(scale.radius))
    scale.grid = std::make_unique<PointGrid>(points, scale.radius);
  return scale;
}

double SplitMerge::exactLevel(const Points3d& points, const Superquadric& model) const {
  if (points.empty()) throw std::invalid_argument("SplitMerge::exactLevel: no points");
  return exactLevel(points, model, scaleOf(points));
}

double SplitMerge::exactLevel(const Points3d& points, const Superquadric& model,
                              const Scale& scale) const {
  double nugget = 0.0;
  if (scale.grid) {
    Indices all(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) all[i] = static_cast<int>(i);
    const std::vector<int> owner(points.size(), 0);
    nugget = residualNoise(points, all, owner, model, *scale.grid, scale.radius);
  }
  return std::max({params_.error_floor_m, params_.noise_factor * scale.plane_noise,
                   exactForNoise(std::max(nugget, sensor_noise_))});
}

std::vector<SuperquadricPart> SplitMerge::run(const Points3d& points, const FitResult* whole,
                                              const FitResult* bounded_whole) const {
  if (points.empty()) throw std::invalid_argument("SplitMerge::run: no points");
  stats_ = Stats();
  auto fit_part = [&](const Indices& indices) {
    return fitter_.fit(subsample(gather(points, indices), params_.split_fit_points),
                       innerIterations(), false, FitMeasures::kSurface);
  };

  // Scale of the data: point spacing (neighbourhoods) and sensor noise. A fit whose mean
  // radial error is below `exact` explains its points within the noise.
  const Scale scale = scaleOf(points);
  stats_.plane_noise_m = stats_.noise_m = scale.plane_noise;
  // One part when the bounded fit explains the points nearly as an exact fit would (its
  // distance measured as the ranking fits' are): a free fit of a one-sided, noisy view often
  // cuts through its points, and splitting then cuts a single box or cylinder into pieces
  // that each fit their few points closer.
  if (bounded_whole && params_.one_part_tolerance >= 0.0 &&
      meanSurfaceDistance(bounded_whole->sq, subsample(points, params_.split_fit_points)) <=
          (1.0 + params_.one_part_tolerance) * exactLevel(points, bounded_whole->sq, scale)) {
    std::vector<SuperquadricPart> one(1);
    one.front().indices.resize(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) one.front().indices[i] = static_cast<int>(i);
    one.front().fit = *bounded_whole;
    return one;
  }
  const double radius = scale.radius;
  const PointGrid* grid = scale.grid.get();
  // Not const: after splitting it is raised to the leaves' typical error (see below).
  double exact = std::max(params_.error_floor_m, params_.noise_factor * stats_.noise_m);

  // ---- Split: a binary tree over the points (Sec. V-C, first step).
  struct Node {
    Indices indices;
    FitResult fit;
    double noise = 0.0;  ///< residual noise of its points about its fit [m]
    int parent = -1;
    bool final = false;
  };
  std::vector<Node> nodes(1);
  nodes[0].indices.resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) nodes[0].indices[i] = static_cast<int>(i);
  if (whole) {
    nodes[0].fit = *whole;
    // Errors are compared on the same subsample sizes as the halves' fits.
    nodes[0].fit.mean_distance =
        meanSurfaceDistance(whole->sq, subsample(points, params_.split_fit_points));
  } else {
    nodes[0].fit = fit_part(nodes[0].indices);
  }
  // Which node each point belongs to (leaves only), for the residual noise of a part.
  std::vector<int> owner(points.size(), 0);
  // The nugget, at least the sensor's own noise (see the header).
  auto part_noise = [&](const Node& node) {
    const double nugget =
        grid ? residualNoise(points, node.indices, owner, node.fit.sq, *grid, radius) : 0.0;
    return std::max(nugget, sensor_noise_);
  };
  nodes[0].noise = part_noise(nodes[0]);
  stats_.residual_noise_m = nodes[0].noise;
  std::vector<int> leaves = {0};
  const std::size_t max_leaves = static_cast<std::size_t>(4 * params_.max_parts);
  const std::size_t min_points = static_cast<std::size_t>(params_.split_min_points);
  while (leaves.size() < max_leaves) {
    // The open leaf with the largest distortion n * e is split first.
    int pick = -1;
    double worst = -1.0;
    for (std::size_t k = 0; k < leaves.size(); ++k) {
      const Node& node = nodes[leaves[k]];
      const double d = node.indices.size() * node.fit.mean_distance;
      if (!node.final && d > worst) {
        worst = d;
        pick = static_cast<int>(k);
      }
    }
    if (pick < 0) break;
    const int id = leaves[pick];
    nodes[id].final = true;  // unless split below
    const Indices& idx = nodes[id].indices;
    const double e = nodes[id].fit.mean_distance;
    // Exact: the fit explains the points within the noise seen in its own residuals (mean
    // distance of pure Gaussian noise: sqrt(2 / pi) sigma), up to the merge's slack t.
    const double exact_here = std::max(exact, exactForNoise(nodes[id].noise));
    if (e <= exact_here || idx.size() < 2 * min_points) continue;
    const PrincipalFrame frame = principalFrame(gather(points, idx));
    const Eigen::Vector3d axis = frame.axes.col(2);  // main inertia axis
    Indices lo, hi;
    for (int i : idx) {
      ((points[static_cast<std::size_t>(i)] - frame.centroid).dot(axis) < 0.0 ? lo : hi)
          .push_back(i);
    }
    if (lo.size() < min_points || hi.size() < min_points) continue;
    FitResult fit_lo, fit_hi;
    detail::parallelFor(2, threads_, [&](int k) {
      if (k == 0) {
        fit_lo = fit_part(lo);
      } else {
        fit_hi = fit_part(hi);
      }
    });
    const double e_split = (lo.size() * fit_lo.mean_distance + hi.size() * fit_hi.mean_distance) /
                           static_cast<double>(idx.size());
    // A cut across a junction can leave both halves mixed and no better than the parent:
    // a part far from explained (e > split_force_factor E) is split regardless.
    if (!(e_split < params_.split_gain * e) && !(e > params_.split_force_factor * exact_here)) {
      continue;
    }
    Node a, b;
    a.indices = std::move(lo);
    a.fit = std::move(fit_lo);
    a.parent = id;
    b.indices = std::move(hi);
    b.fit = std::move(fit_hi);
    b.parent = id;
    const int id_a = static_cast<int>(nodes.size()), id_b = id_a + 1;
    for (int i : a.indices) owner[static_cast<std::size_t>(i)] = id_a;
    for (int i : b.indices) owner[static_cast<std::size_t>(i)] = id_b;
    a.noise = part_noise(a);
    b.noise = part_noise(b);
    nodes.push_back(std::move(a));
    nodes.push_back(std::move(b));
    leaves[pick] = static_cast<int>(nodes.size()) - 2;
    leaves.push_back(static_cast<int>(nodes.size()) - 1);
  }
  std::sort(leaves.begin(), leaves.end());
  const int count = static_cast<int>(leaves.size());
  stats_.leaves = count;

  std::vector<SuperquadricPart> parts(count);
  for (int k = 0; k < count; ++k) {
    parts[k].indices = std::move(nodes[leaves[k]].indices);
    parts[k].fit = std::move(nodes[leaves[k]].fit);
  }
  if (count == 1) {
    if (!whole) completeMeasures(points, parts);
    return parts;
  }

  // The plane RMS underestimates the noise of laser sweeps (points of one scan line are
  // coplanar with the sensor whatever their range noise). Small leaves fit their points at
  // about the noise level, so merging accepts fits within noise_factor times the median
  // leaf error as exact too.
  {
    std::vector<double> leaf_errors;
    for (const auto& part : parts) leaf_errors.push_back(part.fit.mean_distance);
    std::nth_element(leaf_errors.begin(), leaf_errors.begin() + leaf_errors.size() / 2,
                     leaf_errors.end());
    exact = std::max(exact, params_.noise_factor * leaf_errors[leaf_errors.size() / 2]);
    // The leaves' residual noise (median: most leaves are single shapes).
    std::vector<double> leaf_noise;
    for (int id : leaves) leaf_noise.push_back(nodes[id].noise);
    std::nth_element(leaf_noise.begin(), leaf_noise.begin() + leaf_noise.size() / 2,
                     leaf_noise.end());
    stats_.residual_noise_m = leaf_noise[leaf_noise.size() / 2];
  }

  // ---- Topology, computed once: siblings and touching leaves.
  std::vector<std::vector<char>> adjacent(count, std::vector<char>(count, 0));
  for (int i = 0; i < count; ++i) {
    for (int j = i + 1; j < count; ++j) {
      if (nodes[leaves[i]].parent == nodes[leaves[j]].parent) adjacent[i][j] = adjacent[j][i] = 1;
    }
  }
  if (grid) {
    std::vector<int> label(points.size(), 0);
    for (int k = 0; k < count; ++k) {
      for (int i : parts[k].indices) label[static_cast<std::size_t>(i)] = k;
    }
    touchingLeaves(points, *grid, label, radius, adjacent);
  }

  std::vector<SuperquadricPart> out = merge(points, std::move(parts), std::move(adjacent), exact);
  dissolve(points, exact, out);
  reassignBoundaries(points, out);
  completeMeasures(points, out);
  return out;
}

}  // namespace novelty_detection
