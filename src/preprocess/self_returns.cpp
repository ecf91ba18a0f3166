#include "novelty_detection/preprocess/self_returns.h"

#include <pcl/kdtree/kdtree_flann.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace novelty_detection {
namespace {

bool finitePoint(const PointT& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
}

/// The points of `cloud` within max_range of its sensor, in the sensor's frame; the ones
/// closer than min_range or inside `body` (sensor frame) are marked in `mask` directly.
Cloud::Ptr nearInSensorFrame(const Cloud& cloud, double min_range, double max_range,
                             const Eigen::AlignedBox3f& body, std::vector<int>* index,
                             std::vector<std::uint8_t>* mask) {
  const Eigen::Vector3f o = cloud.sensor_origin_.head<3>();
  const Eigen::Matrix3f Rt = cloud.sensor_orientation_.normalized().toRotationMatrix().transpose();
  Cloud::Ptr near(new Cloud);
  mask->assign(cloud.size(), 0);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!finitePoint(cloud[i])) continue;
    const Eigen::Vector3f d = cloud[i].getVector3fMap() - o;
    const float r = d.norm();
    if (r < min_range) {
      (*mask)[i] = 1;
      continue;
    }
    const Eigen::Vector3f l = Rt * d;
    if (!body.isEmpty() && body.contains(l)) {
      (*mask)[i] = 1;
      continue;
    }
    if (r >= max_range) continue;
    near->push_back(PointT(l.x(), l.y(), l.z()));
    index->push_back(static_cast<int>(i));
  }
  return near;
}

/// The points of `cloud` within `radius` of `centre` (map frame), indexed.
struct Around {
  Cloud::Ptr points{new Cloud};
  pcl::KdTreeFLANN<PointT> tree;
  Around(const Cloud& cloud, const Eigen::Vector3f& centre, double radius) {
    for (const auto& p : cloud)
      if (finitePoint(p) && (p.getVector3fMap() - centre).norm() < radius) points->push_back(p);
    if (!points->empty()) tree.setInputCloud(points);
  }
  /// Whether this cloud has a point within tol of `p` (map frame).
  bool matches(const PointT& p, double tol) {
    if (points->empty()) return false;
    std::vector<int> nn(1);
    std::vector<float> d2(1);
    return tree.nearestKSearch(p, 1, nn, d2) == 1 && d2[0] <= tol * tol;
  }
};

/// Marks the points of `a` (sensor frame; a_index into `cloud`) within tol of a point of `b`
/// (the other sweep's sensor frame) that have no point of `other` within map_tol (map frame).
void markMatches(const Cloud::Ptr& a, const std::vector<int>& a_index, const Cloud::Ptr& b,
                 double tol, double map_tol, const Cloud& cloud, Around& other,
                 std::vector<std::uint8_t>* mask) {
  if (a->empty() || b->empty()) return;
  pcl::KdTreeFLANN<PointT> tree;
  tree.setInputCloud(b);
  std::vector<int> nn(1);
  std::vector<float> d2(1);
  const float tol2 = static_cast<float>(tol * tol);
  for (std::size_t k = 0; k < a->size(); ++k)
    if (tree.nearestKSearch((*a)[k], 1, nn, d2) == 1 && d2[0] <= tol2 &&
        !other.matches(cloud[a_index[k]], map_tol))
      (*mask)[a_index[k]] = 1;
}

}  // namespace

Eigen::AlignedBox3f parseBodyBox(const std::string& text) {
  Eigen::AlignedBox3f box;  // empty
  if (text.find_first_not_of(" \t") == std::string::npos) return box;
  std::istringstream in(text);
  Eigen::Vector3f lo, hi;
  std::string rest;
  if (!(in >> lo.x() >> lo.y() >> lo.z() >> hi.x() >> hi.y() >> hi.z()) || (in >> rest) ||
      !lo.allFinite() || !hi.allFinite() || (lo.array() > hi.array()).any()) {
    throw std::invalid_argument("parameter preprocess/body_box = '" + text +
                                "' must be empty or six numbers 'xmin ymin zmin xmax ymax zmax' "
                                "with each min <= max [m]");
  }
  return Eigen::AlignedBox3f(lo, hi);
}

SelfReturns findSelfReturns(const Cloud& reference, const Cloud& current,
                            const PreprocessParams& params, double novelty_distance_m) {
  SelfReturns s;
  s.current.assign(current.size(), 0);
  s.reference.assign(reference.size(), 0);
  const Eigen::AlignedBox3f body = parseBodyBox(params.body_box);
  if (!params.self_filter && params.min_range_m <= 0.0 && body.isEmpty()) return s;
  if (!sensorOriginKnown(reference.sensor_origin_) || !sensorOriginKnown(current.sensor_origin_))
    return s;
  s.checked = true;
  double max_range = params.self_filter ? params.self_max_range_m : 0.0;
  // A sensor that moved (and turned, at the filter's range) by less than the novelty
  // distance sees its robot within that distance of where it was: not a change anyway.
  const double moved =
      (current.sensor_origin_.head<3>() - reference.sensor_origin_.head<3>()).norm() +
      max_range * reference.sensor_orientation_.normalized().angularDistance(
                      current.sensor_orientation_.normalized());
  if (moved < novelty_distance_m) max_range = 0.0;
  std::vector<int> ri, ci;
  const Cloud::Ptr rn =
      nearInSensorFrame(reference, params.min_range_m, max_range, body, &ri, &s.reference);
  const Cloud::Ptr cn =
      nearInSensorFrame(current, params.min_range_m, max_range, body, &ci, &s.current);
  if (rn->size() >= 2 && !cn->empty()) {
    // Tolerance: twice the median nearest-neighbour spacing of the reference's near points.
    pcl::KdTreeFLANN<PointT> tree;
    tree.setInputCloud(rn);
    std::vector<float> spacing;
    std::vector<int> nn(2);
    std::vector<float> d2(2);
    const std::size_t stride = std::max<std::size_t>(1, rn->size() / 2000);
    for (std::size_t k = 0; k < rn->size(); k += stride)
      if (tree.nearestKSearch((*rn)[k], 2, nn, d2) == 2) spacing.push_back(std::sqrt(d2[1]));
    if (!spacing.empty()) {
      std::nth_element(spacing.begin(), spacing.begin() + spacing.size() / 2, spacing.end());
      s.tolerance_m = 2.0 * spacing[spacing.size() / 2];
      const double tol = s.tolerance_m;
      const double map_tol = tol;
      const double reach = max_range + map_tol;
      Around reference_around(reference, current.sensor_origin_.head<3>(), reach);
      Around current_around(current, reference.sensor_origin_.head<3>(), reach);
      markMatches(cn, ci, rn, tol, map_tol, current, reference_around, &s.current);
      markMatches(rn, ri, cn, tol, map_tol, reference, current_around, &s.reference);
    }
  }
  for (auto m : s.current) s.current_count += m;
  for (auto m : s.reference) s.reference_count += m;
  return s;
}

}  // namespace novelty_detection
