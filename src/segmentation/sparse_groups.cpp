#include "novelty_detection/segmentation/sparse_groups.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "common/disjoint_sets.h"
#include "common/knn.h"

namespace novelty_detection {
namespace {

/// Whether the points spread in two directions (kMinSpreadRatio).
bool spreadsInTwoDirections(const std::vector<Eigen::Vector3f>& points, const Indices& members) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int m : members) mean += points[static_cast<std::size_t>(m)].cast<double>();
  mean /= static_cast<double>(members.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (int m : members) {
    const Eigen::Vector3d d = points[static_cast<std::size_t>(m)].cast<double>() - mean;
    cov.noalias() += d * d.transpose();
  }
  const Eigen::Vector3d l =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov, Eigen::EigenvaluesOnly).eigenvalues();
  return l[1] >= kMinSpreadRatio * kMinSpreadRatio * l[2];
}

/// Whether the group stands: its vertical extent (z, the detector's up frame) is at least
/// kMinStandingSpacings times the sweep's spacing at the group's mean range.
bool stands(const std::vector<Eigen::Vector3f>& points, const Indices& members,
            const Eigen::Vector3f& origin, double spacing_ratio) {
  float lo = points[static_cast<std::size_t>(members[0])].z(), hi = lo;
  double range = 0.0;
  for (int m : members) {
    const Eigen::Vector3f& p = points[static_cast<std::size_t>(m)];
    lo = std::min(lo, p.z());
    hi = std::max(hi, p.z());
    range += static_cast<double>((p - origin).norm());
  }
  range /= static_cast<double>(members.size());
  return static_cast<double>(hi - lo) >= kMinStandingSpacings * spacing_ratio * range;
}

}  // namespace

double spacingRatio(const Cloud& cloud, const Indices& points, const std::vector<double>& kth,
                    const Eigen::Vector3f& origin) {
  std::vector<double> ratio;
  ratio.reserve(points.size());
  for (std::size_t k = 0; k < points.size() && k < kth.size(); ++k) {
    const double range = (cloud[points[k]].getVector3fMap() - origin).norm();
    if (range > 0.0 && std::isfinite(range) && std::isfinite(kth[k]))
      ratio.push_back(kth[k] / range);
  }
  if (ratio.empty()) return 0.0;
  std::nth_element(ratio.begin(), ratio.begin() + ratio.size() / 2, ratio.end());
  return ratio[ratio.size() / 2];
}

SparseGroups sparseNovelGroups(const Cloud& cloud, const Indices& removed,
                               const std::vector<Indices>& segments,
                               const std::function<bool(const Eigen::Vector3f&)>& changed,
                               const Eigen::Vector3f& origin, double spacing_ratio,
                               double link_factor, int min_points, GroupShape shape) {
  SparseGroups out;
  out.joined.resize(segments.size());
  if (!(spacing_ratio > 0.0) || !(link_factor > 0.0)) return out;
  // The removed points that changed, and each one's link distance.
  Indices index;
  std::vector<Eigen::Vector3f> points;
  std::vector<double> link;
  for (int i : removed) {
    const Eigen::Vector3f p = cloud[i].getVector3fMap();
    if (!p.allFinite() || !changed(p)) continue;
    index.push_back(i);
    points.push_back(p);
    link.push_back(link_factor * spacing_ratio * static_cast<double>((p - origin).norm()));
  }
  if (points.empty()) return out;
  // Groups: linked when within the larger of the two link distances.
  const detail::KnnTree tree(points);
  detail::DisjointSets groups(points.size());
  std::vector<int> near;
  for (std::size_t i = 0; i < points.size(); ++i) {
    near.clear();
    tree.within(points[i], link[i], &near);
    for (int j : near) groups.unite(static_cast<int>(i), j);
  }
  // The segment each group touches most (the first of equals), if any.
  std::vector<Eigen::Vector3f> segment_points;
  std::vector<int> segment_of;
  for (std::size_t s = 0; s < segments.size(); ++s) {
    for (int i : segments[s]) {
      segment_points.push_back(cloud[i].getVector3fMap());
      segment_of.push_back(static_cast<int>(s));
    }
  }
  const detail::KnnTree segment_tree(segment_points);
  std::vector<std::vector<int>> contacts(points.size());  // per group root, per segment
  for (std::size_t i = 0; i < points.size() && !segment_points.empty(); ++i) {
    near.clear();
    segment_tree.within(points[i], link[i], &near);
    if (near.empty()) continue;
    std::vector<int>& c = contacts[static_cast<std::size_t>(groups.find(static_cast<int>(i)))];
    c.resize(segments.size(), 0);
    for (int j : near) ++c[static_cast<std::size_t>(segment_of[static_cast<std::size_t>(j)])];
  }
  std::vector<Indices> members(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    members[static_cast<std::size_t>(groups.find(static_cast<int>(i)))].push_back(
        static_cast<int>(i));
  for (std::size_t root = 0; root < points.size(); ++root) {
    const Indices& group = members[root];
    if (group.empty()) continue;
    Indices cloud_indices;
    for (int m : group) cloud_indices.push_back(index[static_cast<std::size_t>(m)]);
    const std::vector<int>& c = contacts[root];
    if (!c.empty()) {
      const auto best = std::max_element(c.begin(), c.end()) - c.begin();
      Indices& into = out.joined[static_cast<std::size_t>(best)];
      into.insert(into.end(), cloud_indices.begin(), cloud_indices.end());
      continue;
    }
    if (static_cast<int>(group.size()) < min_points) continue;
    if (shape == GroupShape::kStands ? !stands(points, group, origin, spacing_ratio)
                                     : !spreadsInTwoDirections(points, group))
      continue;
    out.segments.push_back(std::move(cloud_indices));
  }
  for (Indices& j : out.joined) std::sort(j.begin(), j.end());
  for (Indices& s : out.segments) std::sort(s.begin(), s.end());
  std::stable_sort(out.segments.begin(), out.segments.end(),
                   [](const Indices& a, const Indices& b) { return a.size() > b.size(); });
  return out;
}

}  // namespace novelty_detection
