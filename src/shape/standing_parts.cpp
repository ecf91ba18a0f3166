#include "novelty_detection/shape/standing_parts.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <utility>

#include "common/disjoint_sets.h"
#include "novelty_detection/point_grid.h"

namespace novelty_detection {
namespace {

constexpr int kMinLayerPoints = 4;
constexpr double kMinLayerShare = 0.5;
constexpr double kLowQuantile = 0.05, kHighQuantile = 0.95;
constexpr double kLimbQuantile = 0.02;  // the band below's extent, robust to a stray point

struct Layer {
  std::vector<int> points;
  double height = 0.0;     ///< mean height above the floor [m]
  double log_width = 0.0;  ///< log of the 5-95 % range along the main horizontal axis
};

/// The value at quantile q of `values` (the element at floor(q (n - 1)) in order); reorders
/// them.
double quantile(std::vector<double>& values, double q) {
  const std::size_t k = static_cast<std::size_t>(q * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), values.begin() + static_cast<long>(k), values.end());
  return values[k];
}

/// The 5-95 % range of `values`; reorders them.
double innerRange(std::vector<double>& values) {
  return quantile(values, kHighQuantile) - quantile(values, kLowQuantile);
}

/// Points-weighted mean log width of layers [a, b) that pass `keep`.
template <class Keep>
double meanLogWidth(const std::vector<Layer>& layers, int a, int b, Keep&& keep) {
  double sum = 0.0, weight = 0.0;
  for (int j = a; j < b; ++j) {
    if (!keep(j)) continue;
    const double w = static_cast<double>(layers[static_cast<std::size_t>(j)].points.size());
    sum += w * layers[static_cast<std::size_t>(j)].log_width;
    weight += w;
  }
  return weight > 0.0 ? sum / weight : 0.0;
}

/// Connected pieces of `members` (indices into `planar`) linked at `link`.
std::vector<std::vector<int>> pieces(const Points3d& planar, const std::vector<int>& members,
                                     double link) {
  Points3d local;
  local.reserve(members.size());
  for (int i : members) local.push_back(planar[static_cast<std::size_t>(i)]);
  detail::DisjointSets sets(local.size());
  const PointGrid grid(local, link);
  for (std::size_t i = 0; i < local.size(); ++i) {
    grid.forNeighbours(local[i], link, [&](int j) { sets.unite(static_cast<int>(i), j); });
  }
  std::vector<std::vector<int>> out;
  std::vector<int> slot(local.size(), -1);
  for (std::size_t i = 0; i < local.size(); ++i) {
    const int root = sets.find(static_cast<int>(i));
    if (slot[static_cast<std::size_t>(root)] < 0) {
      slot[static_cast<std::size_t>(root)] = static_cast<int>(out.size());
      out.emplace_back();
    }
    out[static_cast<std::size_t>(slot[static_cast<std::size_t>(root)])].push_back(members[i]);
  }
  return out;
}

}  // namespace

std::vector<Indices> standingParts(const Points3d& points, const Eigen::Vector3d& up,
                                   double floor_offset, int min_points) {
  const int n = static_cast<int>(points.size());
  if (min_points < 1 || n < 2 * min_points || !up.allFinite() || up.norm() == 0.0) return {};
  for (const auto& p : points) {
    if (!p.allFinite()) return {};
  }
  Indices all(static_cast<std::size_t>(n));
  std::iota(all.begin(), all.end(), 0);
  const double spacing = medianSpacing(points);
  if (!(spacing > 0.0)) return {all};

  // Heights above the floor and coordinates in the horizontal plane.
  const Eigen::Vector3d z = up.normalized();
  const Eigen::Vector3d x = z.unitOrthogonal(), y = z.cross(x);
  std::vector<double> height(static_cast<std::size_t>(n));
  Points3d planar(static_cast<std::size_t>(n));
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (int i = 0; i < n; ++i) {
    const auto& p = points[static_cast<std::size_t>(i)];
    height[static_cast<std::size_t>(i)] = z.dot(p) + floor_offset;
    planar[static_cast<std::size_t>(i)] = Eigen::Vector3d(x.dot(p), y.dot(p), 0.0);
    mean += planar[static_cast<std::size_t>(i)].head<2>();
  }
  mean /= static_cast<double>(n);
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  for (const auto& q : planar) {
    const Eigen::Vector2d d = q.head<2>() - mean;
    cov += d * d.transpose();
  }
  const Eigen::Vector2d axis =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(cov).eigenvectors().col(1);
  const auto alongOf = [&](int i) {
    return axis.dot(planar[static_cast<std::size_t>(i)].head<2>());
  };

  // Layers, bottom up.
  std::vector<int> order = all;
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    const double ha = height[static_cast<std::size_t>(a)], hb = height[static_cast<std::size_t>(b)];
    return ha < hb || (ha == hb && a < b);
  });
  const double top = height[static_cast<std::size_t>(
      order[static_cast<std::size_t>(0.99 * static_cast<double>(n - 1))])];
  if (!(top > 0.0)) return {all};
  {
    std::vector<double> along;
    along.reserve(all.size());
    for (int i : all) along.push_back(alongOf(i));
    if (top < kTallRatio * innerRange(along)) {
      return {all};
    }
  }
  const double max_thickness = top / kLayersPerHeight;
  std::vector<Layer> layers;
  for (int i : order) {
    const double h = height[static_cast<std::size_t>(i)];
    if (layers.empty() ||
        h - height[static_cast<std::size_t>(layers.back().points.back())] >
            kLayerGapFactor * spacing ||
        h - height[static_cast<std::size_t>(layers.back().points.front())] > max_thickness) {
      layers.emplace_back();
    }
    layers.back().points.push_back(i);
  }
  // Small layers join a neighbour (header comment).
  std::vector<std::size_t> sizes;
  for (const auto& layer : layers) sizes.push_back(layer.points.size());
  std::nth_element(sizes.begin(), sizes.begin() + static_cast<long>(sizes.size() / 2), sizes.end());
  const double min_layer = std::max<double>(
      kMinLayerPoints, kMinLayerShare * static_cast<double>(sizes[sizes.size() / 2]));
  const auto hOf = [&](int i) { return height[static_cast<std::size_t>(i)]; };
  while (layers.size() > 1) {
    std::size_t smallest = 0;
    for (std::size_t j = 1; j < layers.size(); ++j)
      if (layers[j].points.size() < layers[smallest].points.size()) smallest = j;
    if (static_cast<double>(layers[smallest].points.size()) >= min_layer) break;
    const double below = smallest > 0 ? hOf(layers[smallest].points.front()) -
                                            hOf(layers[smallest - 1].points.back())
                                      : std::numeric_limits<double>::infinity();
    const double above = smallest + 1 < layers.size() ? hOf(layers[smallest + 1].points.front()) -
                                                            hOf(layers[smallest].points.back())
                                                      : std::numeric_limits<double>::infinity();
    const std::size_t into = below <= above ? smallest - 1 : smallest + 1;
    auto& target = layers[into].points;
    const auto& from = layers[smallest].points;
    // Layers hold their points in height order.
    target.insert(into < smallest ? target.end() : target.begin(), from.begin(), from.end());
    layers.erase(layers.begin() + static_cast<long>(smallest));
  }
  for (auto& layer : layers) {
    std::vector<double> along;
    double sum = 0.0;
    for (int i : layer.points) {
      along.push_back(alongOf(i));
      sum += height[static_cast<std::size_t>(i)];
    }
    layer.height = sum / static_cast<double>(layer.points.size());
    const double width = innerRange(along);
    layer.log_width = std::log(std::max(width, 2.0 * spacing));
  }

  // Bands: recursive cuts at steps of the section's width.
  const int count = static_cast<int>(layers.size());
  std::vector<int> prefix(static_cast<std::size_t>(count) + 1, 0);
  for (int j = 0; j < count; ++j) {
    prefix[static_cast<std::size_t>(j) + 1] =
        prefix[static_cast<std::size_t>(j)] +
        static_cast<int>(layers[static_cast<std::size_t>(j)].points.size());
  }
  const auto pointsIn = [&](int a, int b) {
    return prefix[static_cast<std::size_t>(b)] - prefix[static_cast<std::size_t>(a)];
  };
  const double window = kWindowFraction * top, min_step = std::log(kSectionStep);
  const auto all_layers = [](int) { return true; };
  std::vector<std::pair<int, int>> bands, stack{{0, count}};
  while (!stack.empty()) {
    const auto [a, b] = stack.back();
    stack.pop_back();
    int cut = -1;
    double best = min_step;
    for (int k = a + 2; k <= b - 2; ++k) {
      if (pointsIn(a, k) < min_points || pointsIn(k, b) < min_points) continue;
      const double below_top = layers[static_cast<std::size_t>(k) - 1].height;
      const double above_bottom = layers[static_cast<std::size_t>(k)].height;
      const double global =
          std::abs(meanLogWidth(layers, a, k, all_layers) - meanLogWidth(layers, k, b, all_layers));
      const double local = std::abs(
          meanLogWidth(layers, a, k,
                       [&](int j) {
                         return below_top - layers[static_cast<std::size_t>(j)].height <= window;
                       }) -
          meanLogWidth(layers, k, b, [&](int j) {
            return layers[static_cast<std::size_t>(j)].height - above_bottom <= window;
          }));
      const double step = std::min(global, local);
      if (step >= best) {
        best = step;
        cut = k;
      }
    }
    if (cut < 0) {
      bands.emplace_back(a, b);
    } else {
      stack.emplace_back(a, cut);
      stack.emplace_back(cut, b);
    }
  }
  std::sort(bands.begin(), bands.end());

  // Pieces of each band; small ones join the part of their nearest point.
  std::vector<std::vector<int>> parts, small;
  const double link = kLinkFactor * spacing;
  double below_log_width = 0.0, below_low = 0.0, below_high = 0.0;
  for (std::size_t band = 0; band < bands.size(); ++band) {
    const auto [a, b] = bands[band];
    std::vector<int> members;
    std::vector<double> along;
    for (int j = a; j < b; ++j) {
      const auto& layer = layers[static_cast<std::size_t>(j)].points;
      members.insert(members.end(), layer.begin(), layer.end());
    }
    for (int i : members) along.push_back(alongOf(i));
    const double log_width = meanLogWidth(layers, a, b, all_layers);
    // Limbs: what overhangs the narrower band below on either side, along the whole band.
    if (band > 0 && log_width - below_log_width >= min_step) {
      double low = std::numeric_limits<double>::infinity(), high = -low;
      for (int i : members) {
        low = std::min(low, height[static_cast<std::size_t>(i)]);
        high = std::max(high, height[static_cast<std::size_t>(i)]);
      }
      for (const double side : {-1.0, 1.0}) {
        std::vector<int> limb, rest;
        double limb_low = std::numeric_limits<double>::infinity(), limb_high = -limb_low;
        for (int i : members) {
          const double t = alongOf(i);
          if (side < 0.0 ? t < below_low - link : t > below_high + link) {
            limb.push_back(i);
            limb_low = std::min(limb_low, height[static_cast<std::size_t>(i)]);
            limb_high = std::max(limb_high, height[static_cast<std::size_t>(i)]);
          } else {
            rest.push_back(i);
          }
        }
        if (static_cast<int>(limb.size()) >= min_points &&
            limb_high - limb_low >= kLimbSpan * (high - low)) {
          parts.push_back(std::move(limb));
          members = std::move(rest);
        }
      }
    }
    below_log_width = log_width;
    below_low = quantile(along, kLimbQuantile);
    below_high = quantile(along, 1.0 - kLimbQuantile);
    const double band_points = static_cast<double>(members.size());
    for (auto& piece : pieces(planar, members, link)) {
      const bool part = static_cast<int>(piece.size()) >= min_points &&
                        static_cast<double>(piece.size()) >= kMinPieceShare * band_points;
      (part ? parts : small).push_back(std::move(piece));
    }
  }
  if (parts.size() < 2) return {all};
  std::vector<int> part_of(static_cast<std::size_t>(n), -1);
  for (std::size_t k = 0; k < parts.size(); ++k) {
    for (int i : parts[k]) part_of[static_cast<std::size_t>(i)] = static_cast<int>(k);
  }
  std::vector<std::pair<int, int>> joins;  // (point, part), applied after the search
  for (const auto& piece : small) {
    for (int i : piece) {
      double best = std::numeric_limits<double>::infinity();
      int best_part = 0;
      for (int j = 0; j < n; ++j) {
        if (part_of[static_cast<std::size_t>(j)] < 0) continue;
        const double d2 =
            (points[static_cast<std::size_t>(j)] - points[static_cast<std::size_t>(i)])
                .squaredNorm();
        if (d2 < best) {
          best = d2;
          best_part = part_of[static_cast<std::size_t>(j)];
        }
      }
      joins.emplace_back(i, best_part);
    }
  }
  for (const auto& [i, k] : joins) part_of[static_cast<std::size_t>(i)] = k;
  std::vector<Indices> out(parts.size());
  for (int i = 0; i < n; ++i)
    out[static_cast<std::size_t>(part_of[static_cast<std::size_t>(i)])].push_back(i);
  std::sort(out.begin(), out.end(),
            [](const Indices& a, const Indices& b) { return a.front() < b.front(); });
  return out;
}

}  // namespace novelty_detection
