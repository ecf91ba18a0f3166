// Pre-processing chain (paper Sec. IV-A): finite points -> sparse outlier removal (Rusu et
// al. 2008) -> ground plane removal (ground_plane.cpp). Indices always refer to the input.
#include "novelty_detection/preprocess/preprocess.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <iterator>
#include <stdexcept>
#include <string>
#include <utility>

#include "common/knn.h"
#include "common/parallel.h"
#include "novelty_detection/preprocess/input_check.h"
#include "novelty_detection/segmentation/novelty_segmentation.h"

namespace novelty_detection {

Indices finiteIndices(const Cloud& cloud) {
  Indices out;
  out.reserve(cloud.size());
  for (int i = 0; i < static_cast<int>(cloud.size()); ++i) {
    const PointT& p = cloud[i];
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) out.push_back(i);
  }
  return out;
}

Indices removeDuplicates(const Cloud& cloud, const Indices& indices, Indices* duplicates,
                         Indices* duplicate_of) {
  if (duplicates) duplicates->clear();
  if (duplicate_of) duplicate_of->clear();
  // An open-addressing table of first occurrences, keyed by the coordinates (+0 added, so
  // that -0 and 0, equal as numbers, share a key): the indices ascend, so the first one
  // seen of each point is its first occurrence.
  std::size_t slots = 16;
  while (slots < 2 * indices.size()) slots *= 2;
  std::vector<int> table(slots, -1);
  const auto key = [&cloud](int i) {
    std::uint32_t k[3];
    const float c[3] = {cloud[i].x + 0.f, cloud[i].y + 0.f, cloud[i].z + 0.f};
    std::memcpy(k, c, sizeof(k));
    std::uint64_t h = (k[0] * 0x9E3779B97F4A7C15ull) ^ (k[1] * 0xC2B2AE3D27D4EB4Full) ^
                      (k[2] * 0x165667B19E3779F9ull);
    return h ^ (h >> 29);
  };
  Indices unique;
  unique.reserve(indices.size());
  for (int i : indices) {
    const PointT& p = cloud[i];
    std::size_t slot = key(i) & (slots - 1);
    for (; table[slot] >= 0; slot = (slot + 1) & (slots - 1)) {
      const PointT& q = cloud[table[slot]];
      if (p.x == q.x && p.y == q.y && p.z == q.z) break;
    }
    if (table[slot] < 0) {
      table[slot] = i;
      unique.push_back(i);
    } else {
      if (duplicates) duplicates->push_back(i);
      if (duplicate_of) duplicate_of->push_back(table[slot]);
    }
  }
  return unique;
}

namespace {

/// The position in `superset` of each of `subset`'s indices (both ascending), as far as they
/// are found there in order: fewer than subset.size() when `subset` is no subset.
std::vector<int> positionsIn(const Indices& superset, const Indices& subset) {
  std::vector<int> out;
  out.reserve(subset.size());
  for (std::size_t e = 0; e < superset.size() && out.size() < subset.size(); ++e)
    if (superset[e] == subset[out.size()]) out.push_back(static_cast<int>(e));
  return out;
}

/// The mean distances to the k nearest other points of `tree`'s points (input indices
/// `points`, ascending), into `stats`. With the statistics of an earlier run over a superset
/// of `points` (`earlier`, its index `earlier_index`; the same points at the same places),
/// the points none of whose lost points lies within their k-th distance keep their values:
/// their k nearest are the same points.
void neighbourStatistics(const NearestNeighbourIndex& tree, const Indices& points, int k,
                         int threads, const PreprocessResult::NeighbourStatistics* earlier,
                         const NearestNeighbourIndex* earlier_index,
                         PreprocessResult::NeighbourStatistics* stats) {
  stats->k = k;
  stats->points = points;
  const std::size_t n = points.size();
  // Positions of the points in the earlier statistics (both ascending), and where the lost
  // ones were.
  std::vector<int> before;
  std::vector<Eigen::Vector3f> lost;
  bool reuse = earlier && earlier_index && earlier->k == k && static_cast<int>(n) > k &&
               earlier->points.size() >= n && earlier->mean.size() == earlier->points.size() &&
               earlier_index->size() == earlier->points.size();
  if (reuse) {
    before = positionsIn(earlier->points, points);
    reuse = before.size() == n;
    for (std::size_t e = 0, j = 0; reuse && e < earlier->points.size(); ++e) {
      if (j < n && before[j] == static_cast<int>(e)) {
        ++j;
      } else {
        lost.push_back(earlier_index->point(static_cast<int>(e)));
      }
    }
    // The same points where they were: a run on another cloud shares nothing.
    for (std::size_t j = 0; j < n && reuse; ++j)
      reuse = tree.point(static_cast<int>(j)) == earlier_index->point(before[j]);
  }
  if (!reuse) {
    stats->mean = tree.meanNeighbourDistances(k, threads, &stats->kth);
    return;
  }
  const detail::KnnTree lost_tree(lost);
  stats->mean.assign(n, 0.0);
  stats->kth.assign(n, 0.0);
  std::vector<char> kept_values(n, 0);
  constexpr int kBlock = 4096;
  detail::parallelForBlocks(static_cast<int>(n), kBlock, threads, [&](int j) {
    const int e = before[static_cast<std::size_t>(j)];
    // No lost point within its k-th distance (the search stops at the first one found; far
    // from every lost point, at the root's box).
    if (!lost_tree.anyWithin(tree.point(j), earlier->kth[e])) {
      stats->mean[j] = earlier->mean[e];
      stats->kth[j] = earlier->kth[e];
      kept_values[static_cast<std::size_t>(j)] = 1;
    } else {
      stats->mean[j] = tree.meanNeighbourDistance(j, k, &stats->kth[j]);
    }
  });
  for (char c : kept_values) stats->reused += c;
}

/// An index over cloud[valid] (ascending): an earlier run's index over a superset of `valid`
/// at the same places restricted to them (linear; its queries are as exact), else built.
std::shared_ptr<NearestNeighbourIndex> indexOf(const Cloud& cloud, const Indices& valid,
                                               const PreprocessResult* earlier, int threads) {
  const NearestNeighbourIndex* before = earlier ? earlier->distinct_index.get() : nullptr;
  const Indices* points = earlier ? &earlier->statistics.points : nullptr;
  if (before && points->size() == before->size()) {
    const std::vector<int> at = positionsIn(*points, valid);
    bool same = at.size() == valid.size();
    std::vector<char> keep(points->size(), 0);
    for (std::size_t j = 0; same && j < at.size(); ++j) {
      same = before->point(at[j]) == cloud[valid[j]].getVector3fMap();
      keep[static_cast<std::size_t>(at[j])] = 1;
    }
    if (same) return std::make_shared<NearestNeighbourIndex>(before->restricted(keep));
  }
  auto tree = std::make_shared<NearestNeighbourIndex>();
  tree->build(cloud, valid, threads);
  return tree;
}

/// Rusu et al. 2008 over `indices`; with `origin`, each mean distance is divided by the
/// point's range (clamped to >= 1 m, where the noise rather than the angular step sets the
/// spacing). `index`, when given, receives the index built over the finite points of
/// `indices`, and `stats` the neighbour statistics (reusing `earlier`'s where they hold).
Indices statisticalOutliers(const Cloud& cloud, const Indices& indices, int k, double std_mul,
                            const Eigen::Vector3f* origin, Indices* removed, int threads,
                            std::shared_ptr<const NearestNeighbourIndex>* index = nullptr,
                            const PreprocessResult* earlier = nullptr,
                            PreprocessResult::NeighbourStatistics* stats = nullptr) {
  if (k < 1) throw std::invalid_argument("removeSparseOutliers: k must be >= 1");
  if (!(std_mul >= 0.0)) {
    throw std::invalid_argument("removeSparseOutliers: std_mul must be >= 0");
  }
  if (origin && !origin->allFinite()) {
    throw std::invalid_argument("removeSparseOutliers: the sensor origin is not finite");
  }
  if (removed) removed->clear();
  Indices valid;  // the finite subset of `indices`; non-finite ones count as removed
  valid.reserve(indices.size());
  for (int i : indices) {
    requireIndexInCloud(cloud, i, "removeSparseOutliers");
    if (cloud[i].getVector3fMap().allFinite()) {
      valid.push_back(i);
    } else if (removed) {
      removed->push_back(i);
    }
  }
  const int n = static_cast<int>(valid.size());
  if (n < 2) return valid;  // no neighbours, no statistics

  // Mean distance to the k nearest neighbours; outliers lie beyond mu + std_mul * sigma of
  // the distribution of those means.
  std::shared_ptr<NearestNeighbourIndex> tree = indexOf(cloud, valid, earlier, threads);
  PreprocessResult::NeighbourStatistics own;
  PreprocessResult::NeighbourStatistics& s = stats ? *stats : own;
  neighbourStatistics(*tree, valid, k, threads, earlier ? &earlier->statistics : nullptr,
                      earlier ? earlier->distinct_index.get() : nullptr, &s);
  const std::vector<double>& mean_dist = s.mean;
  auto limitOf = [n, std_mul](const std::vector<double>& v) {
    double mu = 0.0;
    for (double x : v) mu += x;
    mu /= n;
    double var = 0.0;
    for (double x : v) var += (x - mu) * (x - mu);
    return mu + std_mul * std::sqrt(var / n);
  };
  const double limit = limitOf(mean_dist);
  // With a sensor origin, a point is an outlier only when it is one among the distances
  // divided by range too: a far, sparsely sampled object stays (its spacing is what the
  // range gives), and so do near points that are sparse only next to far ones.
  std::vector<double> scaled;
  double scaled_limit = 0.0;
  if (origin) {
    scaled = mean_dist;
    for (int j = 0; j < n; ++j)
      scaled[j] /= std::max(1.0, static_cast<double>((tree->point(j) - *origin).norm()));
    scaled_limit = limitOf(scaled);
  }
  auto inlier = [&](int j) {
    return mean_dist[j] <= limit || (origin && scaled[j] <= scaled_limit);
  };

  Indices kept;
  kept.reserve(n);
  for (int j = 0; j < n; ++j) {
    if (inlier(j)) {
      kept.push_back(valid[j]);
    } else if (removed) {
      removed->push_back(valid[j]);
    }
  }
  if (index) *index = std::move(tree);
  return kept;
}

}  // namespace

Indices removeSparseOutliers(const Cloud& cloud, const Indices& indices, int k, double std_mul,
                             Indices* removed, int threads) {
  return statisticalOutliers(cloud, indices, k, std_mul, nullptr, removed, threads);
}

Indices removeSparseOutliersRangeScaled(const Cloud& cloud, const Indices& indices, int k,
                                        double std_mul, const Eigen::Vector3f& sensor_origin,
                                        Indices* removed, int threads) {
  return statisticalOutliers(cloud, indices, k, std_mul, &sensor_origin, removed, threads);
}

Preprocessor::Preprocessor(const PreprocessParams& params) : params_(params) { params_.validate(); }

PreprocessResult Preprocessor::compute(const Cloud& cloud) const {
  const Eigen::Vector3f origin = cloud.sensor_origin_.head<3>();
  return compute(cloud, origin, sensorOriginKnown(cloud.sensor_origin_));
}

PreprocessResult Preprocessor::compute(const Cloud& cloud,
                                       const Eigen::Vector3f& sensor_origin) const {
  if (!sensor_origin.allFinite())
    throw std::invalid_argument("Preprocessor: the sensor origin is not finite");
  return compute(cloud, sensor_origin, sensor_origin.allFinite() && !sensor_origin.isZero());
}

PreprocessResult Preprocessor::compute(const Cloud& cloud, const Eigen::Vector3f& sensor_origin,
                                       bool origin_known) const {
  if (cloud.size() > static_cast<std::size_t>(params_.max_points)) {
    throw std::invalid_argument(
        "Preprocessor: cloud has " + std::to_string(cloud.size()) +
        " points, more than preprocess/max_points = " + std::to_string(params_.max_points));
  }
  PreprocessResult result;
  result.finite = finiteIndices(cloud);
  Indices current =
      removeDuplicates(cloud, result.finite, &result.duplicates, &result.duplicate_of);
  if (params_.outlier_removal) {
    const bool scaled = params_.outlier_range_scaled && origin_known;
    current = statisticalOutliers(cloud, current, params_.outlier_k, params_.outlier_std_mul,
                                  scaled ? &sensor_origin : nullptr, &result.outliers, threads_,
                                  &result.distinct_index, earlier_, &result.statistics);
  }
  if (params_.ground_removal) {
    result.ground =
        findGroundPlane(cloud, current, params_, origin_known ? &sensor_origin : nullptr, threads_);
  }
  // current and the ground inliers are both ascending: a linear set difference.
  result.kept.reserve(current.size());
  std::set_difference(current.begin(), current.end(), result.ground.inliers.begin(),
                      result.ground.inliers.end(), std::back_inserter(result.kept));
  return result;
}

}  // namespace novelty_detection
