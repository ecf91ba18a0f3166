// A small static kd-tree for nearest-neighbour queries, private to the core: the k-nearest
// statistics of outlier removal (queried in tree order, for cache locality, and searched
// bottom-up from each query's own leaf, stopping as soon as the k-th neighbour's ball lies
// inside a subtree: about twice PCL's KdTreeFLANN on 30k-point sweeps), and single queries
// from any point (nearest, k-th nearest, within a radius) for the distances to the map and
// segmentation, where KdTreeFLANN's per-query set-up costs more than the search itself.
#pragma once

#include <Eigen/Core>

#include <vector>

namespace novelty_detection {
namespace detail {

class KnnTree {
 public:
  /// An empty tree.
  KnnTree() = default;
  /// Indexes `points` (copied, in any order); results refer to positions in `points`. The
  /// build uses up to `threads` threads (two subtrees at once); the tree is the same.
  explicit KnnTree(const std::vector<Eigen::Vector3f>& points, int threads = 1);

  /// For every point, the mean Euclidean distance to its k nearest OTHER points (k is
  /// clamped to size - 1; 0 when the tree has a single point). Exact.
  /// The points are searched on up to `threads` threads; the result does not depend on it.
  std::vector<double> meanNeighbourDistances(int k, int threads = 1) const;

  /// For every point, the distance to its k-th nearest OTHER point (k clamped as above; 0
  /// when the tree has a single point). Exact.
  std::vector<double> kthNeighbourDistances(int k, int threads = 1) const;

  /// The distance from `p` (any point) to the nearest indexed point; infinity when empty.
  double nearestDistance(const Eigen::Vector3f& p) const;

  /// The distance from `p` (any point) to its k-th nearest indexed point (an indexed point
  /// equal to `p` counts); infinity with fewer than k points. Exact.
  double kthNearestDistance(const Eigen::Vector3f& p, int k) const;

  /// Positions of the indexed points closer than `radius` to `p` (squared distance below
  /// radius^2 in float), appended to `out` in the tree's order (the same for the same points
  /// and query). Exact.
  void within(const Eigen::Vector3f& p, double radius, std::vector<int>* out) const;

  std::size_t size() const { return x_.size(); }

 private:
  struct Node {
    float lo[3], hi[3];  ///< bounding box
    int begin, end;      ///< range in tree order
    int left = -1, right = -1, parent = -1;
  };
  struct Item {
    Eigen::Vector3f p;
    int id;
  };
  static Node nodeOver(const std::vector<Item>& items, int begin, int end, int parent);
  /// Partitions the node's items about the median of its widest side; returns the middle
  /// position, or -1 for a leaf.
  static int split(std::vector<Item>& items, const Node& node);
  static void buildSubtree(std::vector<Item>& items, int begin, int end, std::vector<Node>* nodes,
                           std::vector<int>* leaf_of);
  static constexpr int kLeafSize = 16;
  /// Median splits: 2^kMaxDepth leaves hold far more points than an index can address.
  static constexpr int kMaxDepth = 40;

  /// Runs the k-nearest search for every point and stores reduce(sorted squared distances,
  /// count) at the point's input position.
  template <class Reduce>
  std::vector<double> forEachNeighbourhood(int k, int threads, Reduce reduce) const;
  void search(int node, const float* q, int self, int k, float* d2, int* count) const;

  std::vector<float> x_, y_, z_;  ///< coordinates in tree order
  std::vector<int> id_;           ///< tree order -> input position
  std::vector<int> leaf_of_;      ///< tree position -> leaf node
  std::vector<Node> nodes_;
};

}  // namespace detail
}  // namespace novelty_detection
