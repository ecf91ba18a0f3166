#include "novelty_detection/split_merge.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <unordered_map>

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

/// Median distance of a few evenly spread points to their nearest other point.
double medianSpacing(const Points3d& points) {
  const std::size_t n = points.size();
  if (n < 2) return 0.0;
  const std::size_t samples = std::min<std::size_t>(n, 64);
  std::vector<double> nn;
  nn.reserve(samples);
  for (std::size_t k = 0; k < samples; ++k) {
    const std::size_t i = k * n / samples;
    double best = kInf;
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

/// Marks leaves whose points come closer than `radius` (hash grid with cells of that size).
void touchingLeaves(const Points3d& points, const std::vector<int>& label, double radius,
                    std::vector<std::vector<char>>& adjacent) {
  auto cell = [radius](const Eigen::Vector3d& p) {
    return Eigen::Vector3i(static_cast<int>(std::floor(p.x() / radius)),
                           static_cast<int>(std::floor(p.y() / radius)),
                           static_cast<int>(std::floor(p.z() / radius)));
  };
  auto key = [](const Eigen::Vector3i& c) {
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(c.x())) * 73856093ULL) ^
           (static_cast<std::uint64_t>(static_cast<std::uint32_t>(c.y())) * 19349663ULL) ^
           (static_cast<std::uint64_t>(static_cast<std::uint32_t>(c.z())) * 83492791ULL);
  };
  std::unordered_map<std::uint64_t, std::vector<int>> grid;
  grid.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    grid[key(cell(points[i]))].push_back(static_cast<int>(i));
  }
  const double r2 = radius * radius;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3i c = cell(points[i]);
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it = grid.find(key(c + Eigen::Vector3i(dx, dy, dz)));
          if (it == grid.end()) continue;
          for (int j : it->second) {
            const int li = label[i], lj = label[static_cast<std::size_t>(j)];
            if (li == lj || adjacent[li][lj]) continue;
            if ((points[static_cast<std::size_t>(j)] - points[i]).squaredNorm() <= r2) {
              adjacent[li][lj] = adjacent[lj][li] = 1;
            }
          }
        }
      }
    }
  }
}

}  // namespace

SplitMerge::SplitMerge(const SuperquadricParams& params) : params_(params), fitter_(params) {}

std::vector<SuperquadricPart> SplitMerge::run(const Points3d& points,
                                              const FitResult* whole) const {
  if (points.empty()) throw std::invalid_argument("SplitMerge::run: no points");
  stats_ = Stats();
  auto fit_part = [&](const Indices& indices) {
    return fitter_.fit(subsample(gather(points, indices), params_.split_fit_points));
  };

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
    nodes[0].fit.mean_radial_distance =
        meanRadialDistance(whole->sq, subsample(points, params_.split_fit_points));
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
      const double d = node.indices.size() * node.fit.mean_radial_distance;
      if (!node.final && d > worst) {
        worst = d;
        pick = static_cast<int>(k);
      }
    }
    if (pick < 0) break;
    const int id = leaves[pick];
    nodes[id].final = true;  // unless split below
    const Indices& idx = nodes[id].indices;
    const double e = nodes[id].fit.mean_radial_distance;
    if (e <= params_.error_floor_m || idx.size() < 2 * min_points) continue;
    const PrincipalFrame frame = principalFrame(gather(points, idx));
    const Eigen::Vector3d axis = frame.axes.col(2);  // main inertia axis
    Indices lo, hi;
    for (int i : idx) {
      ((points[static_cast<std::size_t>(i)] - frame.centroid).dot(axis) < 0.0 ? lo : hi)
          .push_back(i);
    }
    if (lo.size() < min_points || hi.size() < min_points) continue;
    FitResult fit_lo = fit_part(lo), fit_hi = fit_part(hi);
    const double e_split = (lo.size() * fit_lo.mean_radial_distance +
                            hi.size() * fit_hi.mean_radial_distance) /
                           static_cast<double>(idx.size());
    if (!(e_split < params_.split_gain * e)) continue;
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

  // ---- Topology, computed once: siblings and touching leaves.
  std::vector<std::vector<char>> adjacent(count, std::vector<char>(count, 0));
  for (int i = 0; i < count; ++i) {
    for (int j = i + 1; j < count; ++j) {
      if (nodes[leaves[i]].parent == nodes[leaves[j]].parent) adjacent[i][j] = adjacent[j][i] = 1;
    }
  }
  const double spacing = medianSpacing(points);
  if (spacing > 0.0) {
    std::vector<int> label(points.size(), 0);
    for (int k = 0; k < count; ++k) {
      for (int i : parts[k].indices) label[static_cast<std::size_t>(i)] = k;
    }
    touchingLeaves(points, label, params_.neighbour_distance_factor * spacing, adjacent);
  }

  // ---- Merge with a memoized cost matrix (Sec. V-C, second step).
  std::vector<char> active(count, 1);
  std::vector<double> cost(static_cast<std::size_t>(count) * count, kInf);
  std::vector<FitResult> merged(static_cast<std::size_t>(count) * count);
  auto at = [count](int i, int j) { return static_cast<std::size_t>(i) * count + j; };
  auto compute = [&](int i, int j) {
    if (i > j) std::swap(i, j);
    FitResult f = fit_part(sortedUnion(parts[i].indices, parts[j].indices));
    cost[at(i, j)] = f.mean_radial_distance;
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
        const double ni = parts[i].indices.size(), nj = parts[j].indices.size();
        const double mean = (ni * parts[i].fit.mean_radial_distance +
                             nj * parts[j].fit.mean_radial_distance) /
                            (ni + nj);
        const double allowed =
            std::max(params_.error_floor_m, (1.0 + params_.merge_tolerance) * mean);
        if (c <= allowed && c < best_ok) {
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
  return out;
}

}  // namespace novelty_detection
