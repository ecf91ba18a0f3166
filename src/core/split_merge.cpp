#include "novelty_detection/split_merge.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <stdexcept>
#include <unordered_map>
#include <utility>

#include <Eigen/Eigenvalues>

#include "detail/parallel.h"
#include "novelty_detection/point_grid.h"
#include "novelty_detection/superquadric.h"

namespace novelty_detection {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kMeanAbsGaussian = 0.7978845608028654;  // E|x| / sigma = sqrt(2 / pi)
constexpr double kMaxLagFraction = 0.1;  // residual noise: median lag <= this x part diagonal

Points3d gather(const Points3d& points, const Indices& indices) {
  Points3d out;
  out.reserve(indices.size());
  for (int i : indices) out.push_back(points[static_cast<std::size_t>(i)]);
  return out;
}

Indices sortedUnion(const Indices& a, const Indices& b) {
  Indices u;
  u.reserve(a.size() + b.size());
  std::merge(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(u));
  return u;
}

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
    std::partial_sort(dist.begin(), dist.begin() + k_max, dist.end());
    for (std::size_t k = std::min<std::size_t>(12, k_max);; k = std::min(k_max, k + k / 2)) {
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
  // Candidates: the few nearest in 3D (the same sheet of surface, not a neighbouring part
  // behind it); of these, the nearest along the tangent plane.
  constexpr std::size_t kCandidates = 6;
  std::vector<std::pair<double, int>> near;
  std::vector<double> sq_diff, lag;
  sq_diff.reserve(samples);
  for (std::size_t s = 0; s < samples; ++s) {
    const Eigen::Vector3d& p = points[static_cast<std::size_t>(part[s * n / samples])];
    const Eigen::Vector3d normal = surfaceNormal(model, p);
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
    const double diff = signedSurfaceDistance(model, p) -
                        signedSurfaceDistance(model, points[static_cast<std::size_t>(nearest)]);
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

std::vector<SuperquadricPart> SplitMerge::run(const Points3d& points,
                                              const FitResult* whole) const {
  if (points.empty()) throw std::invalid_argument("SplitMerge::run: no points");
  stats_ = Stats();
  // Fits inside split and merge only rank candidates: fewer LM iterations suffice.
  const int inner_iterations = std::min(params_.max_iterations, params_.split_iterations);
  auto fit_part = [&](const Indices& indices) {
    return fitter_.fit(subsample(gather(points, indices), params_.split_fit_points),
                       inner_iterations, false);
  };

  // Scale of the data: point spacing (neighbourhoods) and sensor noise. A fit whose mean
  // radial error is below `exact` explains its points within the noise.
  double radius = 0.0;
  neighbourhoodScale(points, &radius, &stats_.plane_noise_m);
  stats_.noise_m = stats_.plane_noise_m;
  radius *= params_.neighbour_distance_factor;
  std::unique_ptr<PointGrid> grid;
  if (radius > 0.0 && std::isfinite(radius)) grid = std::make_unique<PointGrid>(points, radius);
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
  auto part_noise = [&](const Node& node) {
    return grid ? residualNoise(points, node.indices, owner, node.fit.sq, *grid, radius) : 0.0;
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
    const double exact_here =
        std::max(exact, (1.0 + params_.merge_tolerance) * kMeanAbsGaussian * nodes[id].noise);
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
  if (count == 1) return parts;

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

  // ---- Merge with a memoized cost matrix (Sec. V-C, second step).
  std::vector<char> active(count, 1);
  std::vector<double> cost(static_cast<std::size_t>(count) * count, kInf);
  std::vector<FitResult> merged(static_cast<std::size_t>(count) * count);
  auto at = [count](int i, int j) { return static_cast<std::size_t>(i) * count + j; };
  auto compute = [&](int i, int j) {
    if (i > j) std::swap(i, j);
    // The merged model starts from the bigger part's model: cheaper than a multi-start and
    // as good for pieces of one shape (the case where a merge is accepted).
    const Points3d united = subsample(
        gather(points, sortedUnion(parts[i].indices, parts[j].indices)), params_.split_fit_points);
    const int start = parts[i].indices.size() >= parts[j].indices.size() ? i : j;
    FitResult f = fitter_.refine(united, parts[start].fit.sq, inner_iterations, false);
    cost[at(i, j)] = f.mean_distance;
    merged[at(i, j)] = std::move(f);
  };
  // The pairs' fits are independent (each writes its own matrix cells): in parallel.
  auto compute_pairs = [&](const std::vector<std::pair<int, int>>& pairs) {
    detail::parallelFor(static_cast<int>(pairs.size()), threads_, [&](int p) {
      compute(pairs[static_cast<std::size_t>(p)].first, pairs[static_cast<std::size_t>(p)].second);
    });
    stats_.merge_fits += static_cast<int>(pairs.size());
  };
  auto compute_all = [&]() {
    std::vector<std::pair<int, int>> pairs;
    for (int i = 0; i < count; ++i) {
      for (int j = i + 1; j < count; ++j) {
        if (active[i] && active[j] && adjacent[i][j]) pairs.emplace_back(i, j);
      }
    }
    compute_pairs(pairs);
  };
  compute_all();
  for (int i = 0; i < count; ++i) {
    for (int j = i + 1; j < count; ++j) stats_.neighbour_pairs += adjacent[i][j];
  }
  int remaining = count;
  bool costs_fresh = true;
  while (remaining > 1) {
    if (!memoize_ && !costs_fresh) compute_all();
    costs_fresh = false;
    int bi = -1, bj = -1, ai = -1, aj = -1;
    double best_any = kInf, best_ok = kInf;
    for (int i = 0; i < count; ++i) {
      if (!active[i]) continue;
      for (int j = i + 1; j < count; ++j) {
        if (!active[j] || !adjacent[i][j]) continue;
        const double c = cost[at(i, j)];
        if (c < best_any) {
          best_any = c;
          ai = i;
          aj = j;
        }
        // The merged fit is exact, or (Sec. V-C's rule, with the overall distortion in
        // place of the worse part's error, up to the tolerance t) it does not raise the
        // pair's share of the distortion and is not bigger than both parts together.
        const double tol = 1.0 + params_.merge_tolerance;
        const double ni = static_cast<double>(parts[i].indices.size());
        const double nj = static_cast<double>(parts[j].indices.size());
        const double mean =
            (ni * parts[i].fit.mean_distance + nj * parts[j].fit.mean_distance) / (ni + nj);
        const bool allowed =
            c <= exact ||
            (c <= tol * mean && volume(merged[at(i, j)].sq) <=
                                    tol * (volume(parts[i].fit.sq) + volume(parts[j].fit.sq)));
        if (allowed && c < best_ok) {
          best_ok = c;
          bi = i;
          bj = j;
        }
      }
    }
    if (bi < 0) {
      if (remaining <= params_.max_parts) break;
      if (ai < 0) {
        // Too many parts and no neighbours left (disconnected pieces): let every remaining
        // pair be a candidate.
        for (int i = 0; i < count; ++i) {
          for (int j = 0; j < count; ++j) adjacent[i][j] = (i != j && active[i] && active[j]);
        }
        compute_all();
        costs_fresh = true;
        continue;
      }
      bi = ai;
      bj = aj;
    }
    // Merge bj into bi (bi < bj); only bi's row/column of the cost matrix changes.
    parts[bi].indices = sortedUnion(parts[bi].indices, parts[bj].indices);
    parts[bi].fit = merged[at(bi, bj)];
    parts[bj].indices.clear();
    active[bj] = 0;
    --remaining;
    ++stats_.merges;
    for (int k = 0; k < count; ++k) {
      if (adjacent[bj][k] && k != bi) adjacent[bi][k] = adjacent[k][bi] = 1;
      adjacent[bj][k] = adjacent[k][bj] = 0;
      cost[at(std::min(bj, k), std::max(bj, k))] = kInf;
    }
    if (memoize_) {
      std::vector<std::pair<int, int>> pairs;
      for (int k = 0; k < count; ++k) {
        if (k != bi && active[k] && adjacent[bi][k]) pairs.emplace_back(bi, k);
      }
      compute_pairs(pairs);
    }
  }

  std::vector<SuperquadricPart> out;
  for (int k = 0; k < count; ++k) {
    if (active[k]) out.push_back(std::move(parts[k]));
  }

  // Dissolve: a piece cut out of a junction mixes two shapes, fits badly on its own and
  // merges with neither. If the other parts' surfaces explain its points (mean nearest
  // distance <= max(E, (1 + t) e_j)) it is removed and its points join the nearest part.
  // Smallest parts are examined first; receivers are refitted from their models.
  for (bool dissolved = true; dissolved && out.size() > 1;) {
    dissolved = false;
    std::vector<std::size_t> order(out.size());
    for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
    std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
      return out[x].indices.size() < out[y].indices.size();
    });
    for (std::size_t j : order) {
      double sum = 0.0;
      std::vector<std::size_t> target(out[j].indices.size());
      for (std::size_t n = 0; n < out[j].indices.size(); ++n) {
        const Eigen::Vector3d& p = points[static_cast<std::size_t>(out[j].indices[n])];
        double best_d = kInf;
        for (std::size_t k = 0; k < out.size(); ++k) {
          if (k == j) continue;
          const double d = surfaceDistance(out[k].fit.sq, p);
          if (d < best_d) {
            best_d = d;
            target[n] = k;
          }
        }
        sum += best_d;
      }
      const double explained = sum / static_cast<double>(out[j].indices.size());
      if (explained > std::max(exact, (1.0 + params_.merge_tolerance) * out[j].fit.mean_distance)) {
        continue;
      }
      std::vector<Indices> gained(out.size());
      for (std::size_t n = 0; n < out[j].indices.size(); ++n)
        gained[target[n]].push_back(out[j].indices[n]);
      detail::parallelFor(static_cast<int>(out.size()), threads_, [&](int k) {
        if (gained[k].empty()) return;
        out[k].indices = sortedUnion(out[k].indices, gained[k]);
        out[k].fit =
            fitter_.refine(subsample(gather(points, out[k].indices), params_.split_fit_points),
                           out[k].fit.sq, inner_iterations, false);
      });
      out.erase(out.begin() + static_cast<std::ptrdiff_t>(j));
      ++stats_.dissolved;
      dissolved = true;
      break;
    }
  }
  // Boundaries: the split planes cut across junctions, so a part may keep a sliver of its
  // neighbour. Every point moves to the part whose surface is nearest; the changed parts are
  // refitted from their models, and the round is kept only if the total distortion (sum of point
  // distances) drops.
  auto total_distortion = [&](const std::vector<SuperquadricPart>& ps) {
    std::vector<double> sums(ps.size(), 0.0);  // per part, then added in order
    detail::parallelFor(static_cast<int>(ps.size()), threads_, [&](int k) {
      for (int i : ps[k].indices)
        sums[k] += surfaceDistance(ps[k].fit.sq, points[static_cast<std::size_t>(i)]);
    });
    double sum = 0.0;
    for (double v : sums) sum += v;
    return sum;
  };
  double distortion = total_distortion(out);
  for (int round = 0; round < 2 && out.size() > 1; ++round) {
    // Nearest part of every point, per current part (in parallel), then gathered in order.
    std::vector<std::vector<int>> nearest(out.size());
    detail::parallelFor(static_cast<int>(out.size()), threads_, [&](int k) {
      nearest[k].reserve(out[k].indices.size());
      for (int i : out[k].indices) {
        const Eigen::Vector3d& p = points[static_cast<std::size_t>(i)];
        std::size_t best = static_cast<std::size_t>(k);
        double best_d = surfaceDistance(out[k].fit.sq, p);
        for (std::size_t m = 0; m < out.size(); ++m) {
          const double d =
              m == static_cast<std::size_t>(k) ? best_d : surfaceDistance(out[m].fit.sq, p);
          if (d < best_d) {
            best_d = d;
            best = m;
          }
        }
        nearest[k].push_back(static_cast<int>(best));
      }
    });
    std::vector<Indices> assigned(out.size());
    std::vector<char> changed(out.size(), 0);
    for (std::size_t k = 0; k < out.size(); ++k) {
      for (std::size_t n = 0; n < out[k].indices.size(); ++n) {
        const auto best = static_cast<std::size_t>(nearest[k][n]);
        assigned[best].push_back(out[k].indices[n]);
        if (best != k) changed[k] = changed[best] = 1;
      }
    }
    std::vector<SuperquadricPart> next(out.size());
    detail::parallelFor(static_cast<int>(out.size()), threads_, [&](int k) {
      std::sort(assigned[k].begin(), assigned[k].end());
      if (assigned[k].empty()) return;
      next[k].fit =
          changed[k]
              ? fitter_.refine(subsample(gather(points, assigned[k]), params_.split_fit_points),
                               out[k].fit.sq, inner_iterations, false)
              : out[k].fit;
      next[k].indices = std::move(assigned[k]);
    });
    next.erase(std::remove_if(next.begin(), next.end(),
                              [](const SuperquadricPart& p) { return p.indices.empty(); }),
               next.end());
    const double next_distortion = total_distortion(next);
    if (!(next_distortion < distortion)) break;
    distortion = next_distortion;
    out = std::move(next);
  }
  return out;
}

}  // namespace novelty_detection
