// A small static kd-tree for nearest-neighbour queries, private to the core: the k-nearest
// statistics of outlier removal (queried in tree order, for cache locality, and searched
// bottom-up from each query's own leaf, stopping as soon as the k-th neighbour's ball lies
// inside a subtree: about twice PCL's KdTreeFLANN on 30k-point sweeps), and single queries
// from any point (nearest, k-th nearest, within a radius) for the distances to the map and
// segmentation, where KdTreeFLANN's per-query set-up costs more than the search itself.
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <vector>

namespace novelty_detection {
namespace detail {

/// Squared float distance from q to the box [lo, hi] (0 inside).
inline float boxDistance2(const float* q, const float* lo, const float* hi) {
  float d2 = 0.f;
  for (int a = 0; a < 3; ++a) {
    const float t = std::max(std::max(lo[a] - q[a], q[a] - hi[a]), 0.f);
    d2 += t * t;
  }
  return d2;
}

/// Squared float distance from q to the farthest corner of the box [lo, hi]: no point of the
/// box lies farther (float rounding is monotonic).
inline float boxFarDistance2(const float* q, const float* lo, const float* hi) {
  float d2 = 0.f;
  for (int a = 0; a < 3; ++a) {
    const float t = std::max(q[a] - lo[a], hi[a] - q[a]);
    d2 += t * t;
  }
  return d2;
}

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
  /// With `kth`, also each point's distance to its k-th nearest other point.
  std::vector<double> meanNeighbourDistances(int k, int threads = 1,
                                             std::vector<double>* kth = nullptr) const;

  /// The same for the single point at input position `index`: the mean distance to its k
  /// nearest other points (k clamped as above), and the k-th of them in `kth`. Equal to the
  /// entry meanNeighbourDistances() gives it.
  double meanNeighbourDistance(int index, int k, double* kth = nullptr) const;

  /// For every point, the distance to its k-th nearest OTHER point (k clamped as above; 0
  /// when the tree has a single point). Exact.
  std::vector<double> kthNeighbourDistances(int k, int threads = 1) const;

  /// The distance from `p` (any point) to the nearest indexed point; infinity when empty.
  double nearestDistance(const Eigen::Vector3f& p) const;

  /// The distance from `p` (any point) to its k-th nearest indexed point (an indexed point
  /// equal to `p` counts); infinity with fewer than k points. Exact.
  double kthNearestDistance(const Eigen::Vector3f& p, int k) const;

  /// Whether nearestDistance(p) <= radius, found without the exact nearest point: the search
  /// stops at the first point that close (the common case of a point on a mapped surface).
  /// The leaf where the calling thread's last query on this tree found its point is looked
  /// at first: queries from neighbouring points one after another mostly end there.
  bool anyWithin(const Eigen::Vector3f& p, double radius) const;

  /// Whether at least `k` indexed points q satisfy close(d2) for d2 the float squared distance
  /// from `p` to q (computed as nearestDistance() computes it); `close` must be non-increasing
  /// in d2 (true up to some distance). The search stops at the k-th such point: with
  /// close(d2) = f(sqrt(d2)) < x this is f(kthNearestDistance(p, k)) < x, found without the
  /// k-th neighbour.
  /// `leaf` (optional) receives the leaf node holding the k-th such point (unchanged when
  /// there are fewer).
  template <class Close>
  bool atLeast(const Eigen::Vector3f& p, int k, Close close, int* leaf = nullptr) const;

  /// Positions of the indexed points closer than `radius` to `p` (squared distance below
  /// radius^2 in float), appended to `out` in the tree's order (the same for the same points
  /// and query). Exact.
  void within(const Eigen::Vector3f& p, double radius, std::vector<int>* out) const;

  std::size_t size() const { return x_.size(); }
  /// Input positions in the tree's order: a leaf's points, then its neighbour's, ... (queries
  /// made in this order from the indexed points descend the same paths one after another).
  const std::vector<int>& treeOrder() const { return id_; }

  /// The tree restricted to the points at the input positions p with keep[p] != 0 (keep has
  /// one flag per indexed point): the same subtrees, their boxes shrunk to the points they
  /// keep (an emptied one is never entered), the kept points numbered in input order. Every
  /// query is as exact as on a tree built over those points; within() may list them in
  /// another order. Linear in the points: no median is searched again.
  KnnTree restricted(const std::vector<char>& keep) const;

  /// Sums over a set of points in double, of their coordinates relative to `o` (the centre
  /// of the tree's box, so that a covariance taken from them does not cancel for clouds far
  /// from the frame's origin): their number, coordinate sums and the sums of the products
  /// xx, xy, xz, yy, yz, zz.
  struct Moments {
    double o[3] = {0.0, 0.0, 0.0};
    double n = 0.0, s[3] = {0.0, 0.0, 0.0}, ss[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    /// Adds the point at (x, y, z) - o.
    void add(double x, double y, double z);
    /// Adds sums taken about the same o.
    void add(const Moments& m);
  };
  /// Each subtree's moments, kept for momentsWithin() (a tree without them sums point by point).
  void buildMoments();
  /// The moments of the points within() gives for (p, radius): the same points, a subtree
  /// lying wholly inside the ball added at once (its farthest corner is within the radius, so
  /// every point of it passes within()'s test).
  Moments momentsWithin(const Eigen::Vector3f& p, double radius) const;

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
  static_assert(kLeafSize <= 32, "scanLeaf() gives one bit per point of a leaf");
  /// The squared distances from q to the points of the leaf `node` (in tree order) into
  /// dd[0, size), in one pass the compiler vectorises, and a bit j per point whose distance
  /// passes `pass`: the per-point branches of a scan are taken only where points pass.
  template <class Pass>
  unsigned scanLeaf(const Node& node, const float* q, float* dd, Pass pass) const {
    const int m = node.end - node.begin;
    const float* x = x_.data() + node.begin;
    const float* y = y_.data() + node.begin;
    const float* z = z_.data() + node.begin;
    for (int j = 0; j < m; ++j) {
      const float dx = x[j] - q[0], dy = y[j] - q[1], dz = z[j] - q[2];
      dd[j] = dx * dx + dy * dy + dz * dz;
    }
    unsigned bits = 0;
    for (int j = 0; j < m; ++j) bits |= static_cast<unsigned>(pass(dd[j])) << j;
    return bits;
  }
  /// Median splits: 2^kMaxDepth leaves hold far more points than an index can address.
  static constexpr int kMaxDepth = 40;

  /// Runs the k-nearest search for every point and stores reduce(input position, sorted
  /// squared distances, count) at the point's input position.
  template <class Reduce>
  std::vector<double> forEachNeighbourhood(int k, int threads, Reduce reduce) const;
  /// The k nearest other points of tree position t, searched bottom-up from its leaf.
  void searchFromLeaf(int t, int k, float* d2, int* count) const;
  /// Adds the k nearest points of the subtree `node` to q (other than tree position `self`)
  /// into the ascending list d2 of `count` <= k squared distances; entries past `count` must
  /// be +infinity.
  void search(int node, const float* q, int self, int k, float* d2, int* count) const;
  /// The points closer than `radius` to p (float squared distance below radius^2), depth
  /// first in tree order: point(tree position) for each, or with kWhole, whole(node) for a
  /// subtree lying wholly inside the ball.
  template <bool kWhole, class Whole, class Point>
  void visitWithin(const Eigen::Vector3f& p, double radius, Whole whole, Point point) const;
  /// Empty moments about the centre of the tree's box.
  Moments emptyMoments() const;

  std::vector<float> x_, y_, z_;  ///< coordinates in tree order
  std::vector<int> id_;           ///< tree order -> input position
  std::vector<int> leaf_of_;      ///< tree position -> leaf node
  std::vector<int> position_of_;  ///< input position -> tree position
  std::vector<Node> nodes_;
  std::vector<Moments> moments_;  ///< per node, when built
};

template <class Close>
bool KnnTree::atLeast(const Eigen::Vector3f& p, int k, Close close, int* leaf) const {
  if (k <= 0) return true;
  if (nodes_.empty()) return false;
  const float q[3] = {p.x(), p.y(), p.z()};
  // A box's float distance never exceeds that of a point inside it, so `close` prunes boxes
  // too; the nearer child is searched first (the first hits usually lie in the own leaf).
  if (!close(boxDistance2(q, nodes_[0].lo, nodes_[0].hi))) return false;
  int found = 0;
  int stack[2 * kMaxDepth];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const int id = stack[--top];
    const Node& node = nodes_[id];
    if (node.left >= 0) {
      const Node& l = nodes_[node.left];
      const Node& r = nodes_[node.right];
      const float dl = boxDistance2(q, l.lo, l.hi), dr = boxDistance2(q, r.lo, r.hi);
      const bool left_first = dl <= dr;
      if (close(left_first ? dr : dl)) stack[top++] = left_first ? node.right : node.left;
      if (close(left_first ? dl : dr)) stack[top++] = left_first ? node.left : node.right;
      continue;
    }
    float dd[kLeafSize];
    found += __builtin_popcount(scanLeaf(node, q, dd, close));
    if (found >= k) {
      if (leaf) *leaf = id;
      return true;
    }
  }
  return false;
}

}  // namespace detail
}  // namespace novelty_detection
