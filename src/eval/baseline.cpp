// Voxel-difference baseline: OctreePointCloudChangeDetector + EuclideanClusterExtraction.
#include "novelty_detection/eval/baseline.h"

#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/octree/octree_pointcloud_changedetector.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/extract_clusters.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace novelty_detection {
namespace {

// The finite points of a cloud and their indices in it.
Cloud::Ptr finitePoints(const Cloud& cloud, std::vector<int>* index) {
  Cloud::Ptr out(new Cloud);
  out->reserve(cloud.size());
  index->clear();
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const PointT& p = cloud[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
    out->push_back(p);
    index->push_back(static_cast<int>(i));
  }
  out->width = static_cast<std::uint32_t>(out->size());
  out->height = 1;
  out->is_dense = true;
  return out;
}

}  // namespace

void BaselineOptions::validate() const {
  if (!(resolution_m >= 0 && std::isfinite(resolution_m)))
    throw std::invalid_argument("baseline: resolution_m must be >= 0 (0 = from the data)");
  if (!(resolution_factor > 0 && std::isfinite(resolution_factor)))
    throw std::invalid_argument("baseline: resolution_factor must be > 0");
  if (!(cluster_tolerance_factor > 0 && std::isfinite(cluster_tolerance_factor)))
    throw std::invalid_argument("baseline: cluster_tolerance_factor must be > 0");
  if (min_cluster_size < 1) throw std::invalid_argument("baseline: min_cluster_size must be >= 1");
}

double medianPointSpacing(const Cloud& cloud, std::size_t max_samples) {
  std::vector<int> index;
  const Cloud::Ptr pts = finitePoints(cloud, &index);
  if (pts->size() < 2 || max_samples == 0) return 0.0;
  pcl::KdTreeFLANN<PointT> tree;
  tree.setInputCloud(pts);
  const std::size_t n = pts->size(), samples = std::min(n, max_samples);
  std::vector<double> d;
  d.reserve(samples);
  std::vector<int> k(2);
  std::vector<float> d2(2);
  for (std::size_t s = 0; s < samples; ++s) {
    const std::size_t i = s * n / samples;
    if (tree.nearestKSearch((*pts)[i], 2, k, d2) == 2) d.push_back(std::sqrt(d2[1]));
  }
  if (d.empty()) return 0.0;
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  return d[d.size() / 2];
}

std::vector<int> voxelChangeLabels(const Cloud& before, const Cloud& after, double resolution_m,
                                   double cluster_tolerance_m, int min_cluster_size) {
  if (!(resolution_m > 0) || !(cluster_tolerance_m > 0) || min_cluster_size < 1)
    throw std::invalid_argument("voxelChangeLabels: resolution and tolerance must be > 0");
  std::vector<int> labels(after.size(), 0);
  std::vector<int> before_index, after_index;
  const Cloud::Ptr b = finitePoints(before, &before_index);
  const Cloud::Ptr a = finitePoints(after, &after_index);
  if (a->empty()) return labels;

  // Double-buffered octree: the buffer of `before`, then the one of `after`; new voxels
  // are those occupied only in the second.
  pcl::octree::OctreePointCloudChangeDetector<PointT> octree(resolution_m);
  octree.setInputCloud(b);
  octree.addPointsFromInputCloud();
  octree.switchBuffers();
  octree.setInputCloud(a);
  octree.addPointsFromInputCloud();
  std::vector<int> fresh;
  octree.getPointIndicesFromNewVoxels(fresh);
  if (fresh.empty()) return labels;

  Cloud::Ptr changed(new Cloud);
  for (int i : fresh) changed->push_back((*a)[i]);
  pcl::search::KdTree<PointT>::Ptr tree(new pcl::search::KdTree<PointT>);
  tree->setInputCloud(changed);
  pcl::EuclideanClusterExtraction<PointT> ec;
  ec.setClusterTolerance(cluster_tolerance_m);
  ec.setMinClusterSize(min_cluster_size);
  ec.setMaxClusterSize(std::numeric_limits<int>::max());
  ec.setSearchMethod(tree);
  ec.setInputCloud(changed);
  std::vector<pcl::PointIndices> clusters;
  ec.extract(clusters);  // sorted by size, largest first
  for (std::size_t c = 0; c < clusters.size(); ++c)
    for (int j : clusters[c].indices) labels[after_index[fresh[j]]] = static_cast<int>(c) + 1;
  return labels;
}

BaselineResult detectChangesBaseline(const Cloud& reference, const Cloud& current,
                                     const BaselineOptions& options) {
  options.validate();
  BaselineResult r;
  r.resolution_m = options.resolution_m;
  if (r.resolution_m == 0.0) {
    const double spacing = medianPointSpacing(reference);
    if (!(spacing > 0))
      throw std::invalid_argument(
          "baseline: the reference has fewer than two distinct finite points; give "
          "resolution_m");
    r.resolution_m = options.resolution_factor * spacing;
  }
  const double tol = options.cluster_tolerance_factor * r.resolution_m;
  r.labels = voxelChangeLabels(reference, current, r.resolution_m, tol, options.min_cluster_size);
  r.disappeared_labels =
      voxelChangeLabels(current, reference, r.resolution_m, tol, options.min_cluster_size);
  for (int l : r.labels) r.segments = std::max(r.segments, l);
  for (int l : r.disappeared_labels) r.disappeared_segments = std::max(r.disappeared_segments, l);
  return r;
}

BaselineOptions loadBaselineOptions(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const std::exception& e) {
    throw std::runtime_error(path + ": cannot read YAML (" + e.what() + ")");
  }
  const YAML::Node node = root["baseline"] ? root["baseline"] : root;
  BaselineOptions o;
  auto get = [&](const char* key, auto* out) {
    if (!node[key]) return;
    try {
      *out = node[key].as<std::decay_t<decltype(*out)>>();
    } catch (const std::exception&) {
      throw std::runtime_error(path + ": " + key + " has a value of the wrong type");
    }
  };
  if (node.IsMap()) {
    get("resolution_m", &o.resolution_m);
    get("resolution_factor", &o.resolution_factor);
    get("cluster_tolerance_factor", &o.cluster_tolerance_factor);
    get("min_cluster_size", &o.min_cluster_size);
  } else if (node && !node.IsNull()) {
    throw std::runtime_error(path + ": expected a map of baseline options");
  }
  try {
    o.validate();
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
  return o;
}

}  // namespace novelty_detection
