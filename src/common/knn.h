// A small static kd-tree for k-nearest-neighbour statistics among the points of one cloud,
// private to the core. PCL's KdTreeFLANN answers the same queries; this one is about twice
// as fast for the small k of outlier removal (measured on 30k-point sweeps) because it
// queries the points in tree order (cache locality) and searches bottom-up from each
// query's own leaf, stopping as soon as the k-th neighbour's ball lies inside a subtree.
#pragma once

#include <Eigen/Core>

#include <vector>

namespace novelty_detection {
namespace detail {

class KnnTree {
 public:
  /// Indexes `points` (copied, in any order); results refer to positions in `points`.
  explicit KnnTree(const std::vector<Eigen::Vector3f>& points);

  /// For every point, the mean Euclidean distance to its k nearest OTHER points (k is
  /// clamped to size - 1; 0 when the tree has a single point). Exact.
  std::vector<double> meanNeighbourDistances(int k) const;

  /// For every point, the distance to its k-th nearest OTHER point (k clamped as above; 0
  /// when the tree has a single point). Exact.
  std::vector<double> kthNeighbourDistances(int k) const;

  /// The distance from `p` (any point) to the nearest indexed point; infinity when empty.
  double nearestDistance(const Eigen::Vector3f& p) const;

 private:
  struct Node {
    float lo[3], hi[3];  ///< bounding box
    int begin, end;      ///< range in tree order
    int left = -1, right = -1, parent = -1;
  };
  static constexpr int kLeafSize = 16;

  /// Runs the k-nearest search for every point and stores reduce(sorted squared distances,
  /// count) at the point's input position.
  template <class Reduce>
  std::vector<double> forEachNeighbourhood(int k, Reduce reduce) const;
  void search(int node, const float* q, int self, int k, float* d2, int* count) const;

  std::vector<float> x_, y_, z_;  ///< coordinates in tree order
  std::vector<int> id_;           ///< tree order -> input position
  std::vector<int> leaf_of_;      ///< tree position -> leaf node
  std::vector<Node> nodes_;
};

}  // namespace detail
}  // namespace novelty_detection
