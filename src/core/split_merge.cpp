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

#include "novelty_detection/point_grid.h"
#include "novelty_detection/superquadric.h"

namespace novelty_detection {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

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
  const int inner_iterations = std::min(params_.max_iterations, 15);
  auto fit_part = [&](const Indices& indices) {
    return fitter_.fit(subsample(gather(points, indices), params_.split_fit_points),
                       inner_iterations);
  };

  // Scale of the data: point spacing (neighbourhoods) and sensor noise. A fit whose mean
  // radial error is below `exact` explains its points within the noise.
  double radius = 0.0;
  neighbourhoodScale(points, &radius, &stats_.noise_m);
  radius *= params_.neighbour_distance_factor;
  std::unique_ptr<PointGrid> grid;
  if (radius > 0.0 && std::isfinite(radius)) grid = std::make_unique<PointGrid>(points, radius);
  // Not const: after splitting it is raised to the leaves' typical error (see below).
  double exact = std::max(params_.error_floor_m, params_.noise_factor * stats_.noise_m);

  // ---- Split: a binary tree over the points (Sec. V-C, first step).
  struct Node {
    Indices indices;
    FitResult fit;
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
    if (e <= exact || idx.size() < 2 * min_points) continue;
    const PrincipalFrame frame = principalFrame(gather(points, idx));
    const Eigen::Vector3d axis = frame.axes.col(2);  // main inertia axis
    Indices lo, hi;
    for (int i : idx) {
      ((points[static_cast<std::size_t>(i)] - frame.centroid).dot(axis) < 0.0 ? lo : hi)
          .push_back(i);
    }
    if (lo.size() < min_points || hi.size() < min_points) continue;
    FitResult fit_lo = fit_part(lo), fit_hi = fit_part(hi);
    const double e_split = (lo.size() * fit_lo.mean_distance + hi.size() * fit_hi.mean_distance) /
                           static_cast<double>(idx.size());
    // A cut across a junction can leave both halves mixed and no better than the parent:
    // a part far from explained (e > split_force_factor E) is split regardless.
    if (!(e_split < params_.split_gain * e) && !(e > params_.split_force_factor * exact)) {
      continue;
    }
    Node a, b;
    a.indices = std::move(lo);
    a.fit = std::move(fit_lo);
    a.parent = id;
    b.indices = std::move(hi);
    b.fit = std::move(fit_hi);
    b.parent = id;
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
    FitResult f = fitter_.refine(united, parts[start].fit.sq, inner_iterations);
    cost[at(i, j)] = f.mean_distance;
    merged[at(i, j)] = std::move(f);
    ++stats_.merge_fits;
  };
  auto compute_all = [&]() {
    for (int i = 0; i < count; ++i) {
      for (int j = i + 1; j < count; ++j) {
        if (active[i] && active[j] && adjacent[i][j]) compute(i, j);
      }
    }
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
      for (int k = 0; k < count; ++k) {
        if (k != bi && active[k] && adjacent[bi][k]) compute(bi, k);
      }
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
      for (std::size_t k = 0; k < out.size(); ++k) {
        if (gained[k].empty()) continue;
        out[k].indices = sortedUnion(out[k].indices, gained[k]);
        out[k].fit =
            fitter_.refine(subsample(gather(points, out[k].indices), params_.split_fit_points),
                           out[k].fit.sq, inner_iterations);
      }
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
    double sum = 0.0;
    for (const auto& p : ps) {
      for (int i : p.indices) sum += surfaceDistance(p.fit.sq, points[static_cast<std::size_t>(i)]);
    }
    return sum;
  };
  double distortion = total_distortion(out);
  for (int round = 0; round < 2 && out.size() > 1; ++round) {
    std::vector<Indices> assigned(out.size());
    std::vector<char> changed(out.size(), 0);
    for (std::size_t k = 0; k < out.size(); ++k) {
      for (int i : out[k].indices) {
        const Eigen::Vector3d& p = points[static_cast<std::size_t>(i)];
        std::size_t best = k;
        double best_d = surfaceDistance(out[k].fit.sq, p);
        for (std::size_t m = 0; m < out.size(); ++m) {
          const double d = m == k ? best_d : surfaceDistance(out[m].fit.sq, p);
          if (d < best_d) {
            best_d = d;
            best = m;
          }
        }
        assigned[best].push_back(i);
        if (best != k) changed[k] = changed[best] = 1;
      }
    }
    std::vector<SuperquadricPart> next;
    for (std::size_t k = 0; k < out.size(); ++k) {
      std::sort(assigned[k].begin(), assigned[k].end());
      if (assigned[k].empty()) continue;
      SuperquadricPart part;
      part.fit = changed[k] ? fitter_.refine(
                                  subsample(gather(points, assigned[k]), params_.split_fit_points),
                                  out[k].fit.sq, inner_iterations)
                            : out[k].fit;
      part.indices = std::move(assigned[k]);
      next.push_back(std::move(part));
    }
    const double next_distortion = total_distortion(next);
    if (!(next_distortion < distortion)) break;
    distortion = next_distortion;
    out = std::move(next);
  }
  return out;
}

}  // namespace novelty_detection
