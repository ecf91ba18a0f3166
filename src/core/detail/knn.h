// A small static kd-tree for k-nearest-neighbour queries among the points of one cloud,
// private to the core. PCL's KdTreeFLANN answers the same queries; this one is several
// times faster for the small k of outlier removal because it queries the points in tree
// order (cache locality) and seeds each search with the query's own leaf.
#pragma once

#include <Eigen/Core>

#include <vector>

namespace novelty_detection {
namespace detail {

class KnnTree {
 public:
  /// Indexes `points` (copied, in any order); queries refer to positions in `points`.
  explicit KnnTree(const std::vector<Eigen::Vector3f>& points);

  /// For every point, the mean Euclidean distance to its k nearest OTHER points (k is
  /// clamped to size - 1; 0 when the tree has a single point). Exact.
  /// When `neighbours` is given it receives, per point, its k nearest others (input
  /// positions, nearest first; k * size entries).
  std::vector<double> meanNeighbourDistances(int k, std::vector<int>* neighbours = nullptr) const;

 private:
  struct Node {
    Eigen::Vector3f lo, hi;  ///< bounding box
    int begin, end;          ///< range in pts_
    int left = -1, right = -1;
  };
  static constexpr int kLeafSize = 8;

  int buildNode(int begin, int end);
  void search(int node, const Eigen::Vector3f& q, int self, int k, float* d2, int* who,
              int* count, int skip_node) const;

  std::vector<Eigen::Vector3f> pts_;  ///< tree order
  std::vector<int> id_;               ///< tree order -> input position
  std::vector<int> leaf_of_;          ///< tree position -> leaf node
  std::vector<Node> nodes_;
};

}  // namespace detail
}  // namespace novelty_detection
