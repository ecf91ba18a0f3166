// Merge phase of split and merge (paper Sec. V-C, second step): greedy merge of the leaves
// with a memoized merge-cost matrix, dissolution of junction pieces, and reassignment of
// boundary points to the nearest part surface. The split phase is in split_merge.cpp.
#include <algorithm>
#include <cstddef>
#include <limits>
#include <utility>

#include "common/parallel.h"
#include "novelty_detection/shape/split_merge.h"
#include "novelty_detection/shape/superquadric.h"
#include "shape/point_subsets.h"

namespace novelty_detection {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

}  // namespace

using detail::sortedUnion;

std::vector<SuperquadricPart> SplitMerge::merge(const Points3d& points,
                                                std::vector<SuperquadricPart> parts,
                                                std::vector<std::vector<char>> adjacent,
                                                double exact) const {
  // Merge with a memoized cost matrix (Sec. V-C, second step).
  const int count = static_cast<int>(parts.size());
  std::vector<char> active(count, 1);
  std::vector<double> cost(static_cast<std::size_t>(count) * count, kInf);
  std::vector<FitResult> merged(static_cast<std::size_t>(count) * count);
  auto at = [count](int i, int j) { return static_cast<std::size_t>(i) * count + j; };
  auto compute = [&](int i, int j) {
    if (i > j) std::swap(i, j);
    // The merged model starts from the bigger part's model: cheaper than a multi-start and
    // as good for pieces of one shape (the case where a merge is accepted).
    const int start = parts[i].indices.size() >= parts[j].indices.size() ? i : j;
    FitResult f =
        refitPart(points, sortedUnion(parts[i].indices, parts[j].indices), parts[start].fit.sq);
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
  return out;
}

void SplitMerge::dissolve(const Points3d& points, double exact,
                          std::vector<SuperquadricPart>& out) const {
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
    std::vector<SurfaceQuery> surfaces;
    for (const auto& part : out) surfaces.emplace_back(part.fit.sq);
    for (std::size_t j : order) {
      double sum = 0.0;
      std::vector<std::size_t> target(out[j].indices.size());
      std::vector<std::vector<double>> dist(out.size());  // [part][point of j]
      for (std::size_t k = 0; k < out.size(); ++k) {
        if (k == j) continue;
        dist[k].resize(out[j].indices.size());
        surfaces[k].distances(points, out[j].indices, dist[k].data());
      }
      for (std::size_t n = 0; n < out[j].indices.size(); ++n) {
        double best_d = kInf;
        for (std::size_t k = 0; k < out.size(); ++k) {
          if (k == j) continue;
          const double d = dist[k][n];
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
        out[k].fit = refitPart(points, out[k].indices, out[k].fit.sq);
      });
      out.erase(out.begin() + static_cast<std::ptrdiff_t>(j));
      ++stats_.dissolved;
      dissolved = true;
      break;
    }
  }
}

void SplitMerge::reassignBoundaries(const Points3d& points,
                                    std::vector<SuperquadricPart>& out) const {
  // Boundaries: the split planes cut across junctions, so a part may keep a sliver of its
  // neighbour. Every point moves to the part whose surface is nearest; the changed parts are
  // refitted from their models, and the round is kept only if the total distortion (sum of point
  // distances) drops.
  auto total_distortion = [&](const std::vector<SuperquadricPart>& ps) {
    std::vector<double> sums(ps.size(), 0.0);  // per part, then added in order
    detail::parallelFor(static_cast<int>(ps.size()), threads_, [&](int k) {
      std::vector<double> d(ps[k].indices.size());
      SurfaceQuery(ps[k].fit.sq).distances(points, ps[k].indices, d.data());
      for (double v : d) sums[k] += v;
    });
    double sum = 0.0;
    for (double v : sums) sum += v;
    return sum;
  };
  double distortion = total_distortion(out);
  for (int round = 0; round < 2 && out.size() > 1; ++round) {
    // Nearest part of every point, per current part (in parallel), then gathered in order.
    std::vector<std::vector<int>> nearest(out.size());
    std::vector<SurfaceQuery> surfaces;
    for (const auto& part : out) surfaces.emplace_back(part.fit.sq);
    detail::parallelFor(static_cast<int>(out.size()), threads_, [&](int k) {
      const std::size_t count = out[k].indices.size();
      nearest[k].reserve(count);
      std::vector<double> dist(out.size() * count);  // part m's distances at m * count
      for (std::size_t m = 0; m < out.size(); ++m) {
        surfaces[m].distances(points, out[k].indices, dist.data() + m * count);
      }
      for (std::size_t n = 0; n < count; ++n) {
        std::size_t best = static_cast<std::size_t>(k);
        double best_d = dist[static_cast<std::size_t>(k) * count + n];
        for (std::size_t m = 0; m < out.size(); ++m) {
          const double d = m == static_cast<std::size_t>(k) ? best_d : dist[m * count + n];
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
      next[k].fit = changed[k] ? refitPart(points, assigned[k], out[k].fit.sq) : out[k].fit;
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
}

}  // namespace novelty_detection
