// Pauly, Gross & Kobbelt (2002) hierarchical clustering, built once and cut at any scale
// (paper Sec. IV-A).
//
// Build: every node keeps its first and second moments in double, centred on its PARENT's
// centroid (a point close to the node, so the covariance E[xx^T] - mm^T does not cancel
// catastrophically even for clouds far from the origin). Splitting a node partitions its
// range of order_ in place around the plane through its centroid normal to the eigenvector
// of the largest eigenvalue, and accumulates both children's moments in the same pass; the
// build is therefore one pass per tree level, O(N log N).
#include "novelty_detection/preprocess/multiscale_tree.h"

#include "common/parallel.h"
#include "novelty_detection/preprocess/input_check.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>

namespace novelty_detection {
namespace {

/// Running sums of a point set, relative to an origin o: n, sum(p - o), sum((p-o)(p-o)^T)
/// (its upper triangle: xx, xy, xz, yy, yz, zz; the lower one holds the same products).
struct Moments {
  double n = 0.0;
  Eigen::Vector3d s = Eigen::Vector3d::Zero();
  double ss[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};

  void add(const Eigen::Vector3d& d) {
    n += 1.0;
    s += d;
    ss[0] += d.x() * d.x(), ss[1] += d.x() * d.y(), ss[2] += d.x() * d.z();
    ss[3] += d.y() * d.y(), ss[4] += d.y() * d.z(), ss[5] += d.z() * d.z();
  }
  Eigen::Matrix3d products() const {
    Eigen::Matrix3d m;
    m << ss[0], ss[1], ss[2], ss[1], ss[3], ss[4], ss[2], ss[4], ss[5];
    return m;
  }
  double trace() const { return ss[0] + ss[3] + ss[5]; }
};

struct Stats {
  Eigen::Vector3d centroid;
  Eigen::Matrix3d covariance;
  Eigen::Vector3d eigenvalues;  ///< ascending, clamped at 0
  Eigen::Vector3d major_axis;   ///< eigenvector of the largest eigenvalue
};

/// The statistics of the points of `m`; the major axis only `with_axis` (a node that is
/// split): the eigenvalues come out the same either way.
Stats statsOf(const Moments& m, const Eigen::Vector3d& origin, bool with_axis) {
  Stats st;
  const Eigen::Vector3d mean = m.s / m.n;
  st.centroid = origin + mean;
  st.covariance = m.products() / m.n - mean * mean.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(st.covariance, with_axis ? Eigen::ComputeEigenvectors : Eigen::EigenvaluesOnly);
  st.eigenvalues = es.eigenvalues().cwiseMax(0.0);
  st.major_axis = with_axis ? Eigen::Vector3d(es.eigenvectors().col(2)) : Eigen::Vector3d::Zero();
  return st;
}

/// Surface variation sigma = l0 / (l0 + l1 + l2) (Pauly et al. 2002, eq. 2); 0 for a
/// cluster without spread (one point or duplicates), which is as flat as it gets.
double surfaceVariation(const Eigen::Vector3d& l) {
  const double total = l.sum();
  return total > 0.0 ? l(0) / total : 0.0;
}

}  // namespace

namespace {

/// A tree under construction: nodes with their moments (each relative to its origin) and
/// their depth, in creation order.
struct Growing {
  std::vector<MultiScaleTree::Node> nodes;
  std::vector<Moments> moments;
  std::vector<Eigen::Vector3d> origins;
  std::vector<int> depth;

  void reserve(std::size_t n) {
    nodes.reserve(n);
    moments.reserve(n);
    origins.reserve(n);
    depth.reserve(n);
  }
  /// Starts the tree at `root` (its parent unset: the root here).
  void addRoot(MultiScaleTree::Node root, const Moments& m, const Eigen::Vector3d& origin) {
    root.parent = -1;
    nodes.push_back(root);
    moments.push_back(m);
    origins.push_back(origin);
    depth.push_back(0);
  }
};

/// Splits the nodes of `t` in creation order, from the first, those above depth `depth_limit`
/// (the children are appended: processing them in that order is a BFS, level by level). A
/// node's points stay within its range of pts and order: trees over disjoint ranges can grow
/// at once.
void grow(Growing& t, std::vector<Eigen::Vector3d>& pts, Indices& order,
          int depth_limit = std::numeric_limits<int>::max()) {
  using Node = MultiScaleTree::Node;
  constexpr int kMaxLeafSize = MultiScaleTree::kMaxLeafSize;
  for (std::size_t id = 0; id < t.nodes.size() && t.depth[id] < depth_limit; ++id) {
    const int size = t.nodes[id].size();
    const Stats st = statsOf(t.moments[id], t.origins[id], size > kMaxLeafSize);
    Node& node = t.nodes[id];
    node.centroid = st.centroid.cast<float>();
    node.covariance = st.covariance.cast<float>();
    node.sigma = static_cast<float>(surfaceVariation(st.eigenvalues));
    node.eigenvalues = st.eigenvalues.cast<float>();

    if (size <= kMaxLeafSize) continue;
    // Duplicates only: splitting cannot separate them, so they form one leaf. The exact
    // check runs only when the spread is at rounding level of the moments.
    const Moments& m = t.moments[id];
    if (st.eigenvalues(2) <= 1e-10 * (m.trace() / m.n) &&
        std::all_of(pts.begin() + node.begin, pts.begin() + node.end,
                    [&](const Eigen::Vector3d& p) { return p == pts[node.begin]; })) {
      continue;
    }

    // Partition [begin, end) by the side of the split plane (Pauly et al. 2002, Sec. 3.1).
    const Eigen::Vector3d c = st.centroid;
    const Eigen::Vector3d axis = st.major_axis;
    int lo = node.begin, hi = node.end - 1;
    while (lo <= hi) {
      if ((pts[lo] - c).dot(axis) < 0.0) {
        ++lo;
      } else {
        std::swap(pts[lo], pts[hi]);
        std::swap(order[lo], order[hi]);
        --hi;
      }
    }
    int mid = lo;
    if (mid == node.begin || mid == node.end) {
      // Rounding left one side empty (near-duplicates far from the origin): split at the
      // median projection instead, which always makes progress.
      mid = node.begin + size / 2;
      std::vector<std::pair<double, int>> proj(size);
      for (int k = 0; k < size; ++k) {
        proj[k] = {pts[node.begin + k].dot(axis), k};
      }
      std::nth_element(proj.begin(), proj.begin() + size / 2, proj.end());
      std::vector<Eigen::Vector3d> p2(size);
      Indices o2(size);
      for (int k = 0; k < size; ++k) {
        p2[k] = pts[node.begin + proj[k].second];
        o2[k] = order[node.begin + proj[k].second];
      }
      std::copy(p2.begin(), p2.end(), pts.begin() + node.begin);
      std::copy(o2.begin(), o2.end(), order.begin() + node.begin);
    }
    Moments ml, mr;
    for (int k = node.begin; k < mid; ++k) ml.add(pts[k] - c);
    for (int k = mid; k < node.end; ++k) mr.add(pts[k] - c);

    Node left, right;
    left.begin = node.begin;
    left.end = mid;
    right.begin = mid;
    right.end = node.end;
    left.parent = right.parent = static_cast<int>(id);
    const int left_id = static_cast<int>(t.nodes.size());
    t.nodes[id].left = left_id;  // `node` may dangle after the push_backs below
    t.nodes[id].right = left_id + 1;
    t.nodes.push_back(left);
    t.nodes.push_back(right);
    t.depth.push_back(t.depth[id] + 1);
    t.depth.push_back(t.depth[id] + 1);
    t.moments.push_back(ml);
    t.moments.push_back(mr);
    t.origins.push_back(c);
    t.origins.push_back(c);
  }
}

/// The tree `top` grown down to a level whose nodes (the frontier, the last nodes of `top`
/// from `first`) grew apart as the trees `part` (part[k] rooted at top.nodes[first + k]),
/// numbered as one BFS from the root numbers them: level by level, and within a level the
/// nodes under an earlier frontier node first (each part's own BFS keeps its levels in order).
std::vector<MultiScaleTree::Node> mergeSubtrees(const Growing& top, std::size_t first,
                                                const std::vector<Growing>& part) {
  const std::size_t parts = part.size();
  std::vector<MultiScaleTree::Node> nodes(top.nodes.begin(),
                                          top.nodes.begin() + static_cast<std::ptrdiff_t>(first));
  std::size_t total = first;
  for (const Growing& g : part) total += g.nodes.size();
  nodes.reserve(total);
  std::vector<std::vector<int>> global(parts);
  for (std::size_t k = 0; k < parts; ++k) global[k].assign(part[k].nodes.size(), -1);
  std::vector<std::size_t> next(parts, 0);
  for (int level = 0; nodes.size() < total; ++level) {
    for (std::size_t k = 0; k < parts; ++k) {
      for (; next[k] < part[k].nodes.size() && part[k].depth[next[k]] == level; ++next[k]) {
        global[k][next[k]] = static_cast<int>(nodes.size());
        nodes.push_back(part[k].nodes[next[k]]);
      }
    }
  }
  for (std::size_t k = 0; k < parts; ++k) {
    for (std::size_t j = 0; j < part[k].nodes.size(); ++j) {
      MultiScaleTree::Node& node = nodes[static_cast<std::size_t>(global[k][j])];
      node.parent = node.parent < 0 ? top.nodes[first + k].parent
                                    : global[k][static_cast<std::size_t>(node.parent)];
      if (node.left >= 0) {
        node.left = global[k][static_cast<std::size_t>(node.left)];
        node.right = global[k][static_cast<std::size_t>(node.right)];
      }
    }
  }
  return nodes;
}

}  // namespace

void MultiScaleTree::build(const Cloud& cloud, const Indices& indices, int threads) {
  nodes_.clear();
  order_.clear();
  cloud_size_ = cloud.size();
  noise_variance_m2_ = 0.0;

  auto finite = [&cloud](int i) {
    const PointT& p = cloud[i];
    return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
  };
  if (indices.empty()) {
    order_.reserve(cloud.size());
    for (int i = 0; i < static_cast<int>(cloud.size()); ++i) {
      if (finite(i)) order_.push_back(i);
    }
  } else {
    std::vector<char> seen(cloud.size(), 0);
    order_.reserve(indices.size());
    for (int i : indices) {
      requireIndexInCloud(cloud, i, "MultiScaleTree::build");
      if (seen[i]) {
        throw std::invalid_argument("MultiScaleTree::build: index " + std::to_string(i) +
                                    " given twice");
      }
      seen[i] = 1;
      if (finite(i)) order_.push_back(i);  // non-finite points are left out (cluster -1)
    }
  }
  const int n = static_cast<int>(order_.size());
  if (n == 0) return;

  // Points in tree order, permuted together with order_ (contiguous, cache friendly).
  std::vector<Eigen::Vector3d> pts(n);
  for (int k = 0; k < n; ++k) pts[k] = cloud[order_[k]].getVector3fMap().cast<double>();

  // A binary tree with leaves of >= 1 point has at most 2n - 1 nodes; one of leaves of up
  // to kMaxLeafSize points far fewer.
  const auto capacity = [](int points) {
    return static_cast<std::size_t>(2 * points / std::max(1, kMaxLeafSize / 2) + 1);
  };
  const bool parallel = threads > 1 && n >= detail::kMinPointsForParallelBuild;
  // Levels split before the threads take the subtrees below them (up to 2^kParallelDepth).
  constexpr int kParallelDepth = 3;
  Growing whole;
  {
    // The parallel build keeps only the top levels here; each subtree below them holds its
    // own nodes while it grows.
    whole.reserve(parallel ? (2u << kParallelDepth) : capacity(n));
    Node root;
    root.begin = 0;
    root.end = n;
    Moments m;
    const Eigen::Vector3d o = pts[0];  // any point of the cloud keeps sums well scaled
    for (const auto& p : pts) m.add(p - o);
    whole.addRoot(root, m, o);
  }
  if (parallel) {
    // The top levels here, the subtrees below them on the threads (largest first: a split at
    // the centroid leaves siblings of unequal size), then numbered as the serial BFS numbers
    // them.
    grow(whole, pts, order_, kParallelDepth);
    std::size_t first = whole.nodes.size();
    while (first > 0 && whole.depth[first - 1] == kParallelDepth) --first;
    std::vector<Growing> part(whole.nodes.size() - first);
    std::vector<int> largest(part.size());
    for (std::size_t k = 0; k < part.size(); ++k) {
      const std::size_t id = first + k;
      part[k].reserve(capacity(whole.nodes[id].size()));
      part[k].addRoot(whole.nodes[id], whole.moments[id], whole.origins[id]);
      largest[k] = static_cast<int>(k);
    }
    std::stable_sort(largest.begin(), largest.end(), [&](int a, int b) {
      return whole.nodes[first + a].size() > whole.nodes[first + b].size();
    });
    detail::parallelFor(static_cast<int>(part.size()), threads, [&](int j) {
      Growing& g = part[static_cast<std::size_t>(largest[j])];
      grow(g, pts, order_);
      // The moments served the splits only: freed before the nodes are copied.
      std::vector<Moments>().swap(g.moments);
      std::vector<Eigen::Vector3d>().swap(g.origins);
    });
    if (!part.empty()) whole.nodes = mergeSubtrees(whole, first, part);
  } else {
    grow(whole, pts, order_);
  }
  nodes_.swap(whole.nodes);

  // Noise: on a plane, n * l0 / noise_var is chi-square with n - 3 degrees of freedom (the
  // residuals about the fitted plane), whose median is ~ nu (1 - 2 / (9 nu))^3; dividing
  // that out makes every node an unbiased vote, and the median of the votes ignores the
  // minority of nodes on edges and corners.
  std::vector<double> l0;
  for (const Node& node : nodes_) {
    const double vote = noiseVote(node);
    if (vote >= 0.0) l0.push_back(vote);
  }
  if (!l0.empty()) {
    std::nth_element(l0.begin(), l0.begin() + l0.size() / 2, l0.end());
    noise_variance_m2_ = l0[l0.size() / 2];
  }
}

double MultiScaleTree::noiseVote(const Node& node) {
  const int size = node.size();
  // Plate-like nodes only: where the in-plane spread is not far above the noise, splits
  // start cutting through the noise itself and the small l0 left would bias the vote.
  if (size < 16 || size > 256 || node.eigenvalues(1) < 10.f * node.eigenvalues(0)) return -1.0;
  const double nu = size - 3.0;
  const double median_factor = std::pow(1.0 - 2.0 / (9.0 * nu), 3.0);
  return node.eigenvalues(0) * size / (nu * median_factor);
}

MultiScaleTree::Cut MultiScaleTree::cut(int n_max, double sigma_max) const {
  return cut(n_max, sigma_max, 0.0);
}

MultiScaleTree::Cut MultiScaleTree::cut(int n_max, double sigma_max, double noise_var_m2) const {
  if (n_max < 1) throw std::invalid_argument("MultiScaleTree::cut: n_max must be >= 1");
  if (!(sigma_max >= 0.0)) {
    throw std::invalid_argument("MultiScaleTree::cut: sigma_max must be >= 0");
  }
  if (!(noise_var_m2 >= 0.0)) {
    throw std::invalid_argument("MultiScaleTree::cut: noise_var_m2 must be >= 0");
  }
  // Surface variation with the noise's share of l0 taken out (exactly Pauly's for 0).
  auto flat = [&](const Node& node) {
    if (noise_var_m2 == 0.0) return node.sigma <= sigma_max;
    const double total = node.eigenvalues.cast<double>().sum();
    const double excess = std::max(0.0, node.eigenvalues(0) - noise_var_m2);
    return total <= 0.0 || excess <= sigma_max * total;
  };
  Cut cut;
  cut.cluster_of.assign(cloud_size_, -1);
  if (nodes_.empty()) return cut;

  // Top-down: the first node on each root-to-leaf path that is small and flat enough is a
  // cluster (Pauly et al. split while |P| > n_max or sigma > sigma_max).
  std::vector<int> stack{0};
  while (!stack.empty()) {
    const int id = stack.back();
    stack.pop_back();
    const Node& node = nodes_[id];
    if (node.isLeaf() || (node.size() <= n_max && flat(node))) {
      const int cluster = static_cast<int>(cut.nodes.size());
      cut.nodes.push_back(id);
      cut.points.push_back(node.centroid);
      cut.sizes.push_back(node.size());
      for (int k = node.begin; k < node.end; ++k) cut.cluster_of[order_[k]] = cluster;
    } else {
      stack.push_back(node.right);  // left popped first: clusters follow tree order
      stack.push_back(node.left);
    }
  }
  return cut;
}

MultiScaleTree::Cut MultiScaleTree::cut(const MultiScaleParams& params) const {
  params.validate();
  return cut(params.n_max, params.sigma_max,
             params.noise_aware ? params.noise_factor * noise_variance_m2_ : 0.0);
}

Indices MultiScaleTree::nodeIndices(int node) const {
  if (node < 0 || node >= static_cast<int>(nodes_.size())) {
    throw std::out_of_range("MultiScaleTree::nodeIndices: no node " + std::to_string(node));
  }
  const Node& n = nodes_[node];
  return Indices(order_.begin() + n.begin, order_.begin() + n.end);
}

}  // namespace novelty_detection
