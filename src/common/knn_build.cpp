// The k-d tree's construction (knn.h): median splits along the widest side, two subtrees at
// once on two threads, and a tree restricted to a subset of its points.
#include "common/knn.h"

#include "common/parallel.h"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <vector>

namespace novelty_detection {
namespace detail {
/// Builds the subtree of items[begin, end) into `nodes` (empty) in depth-first preorder, its
/// root without a parent, and the leaf of each item position.
void KnnTree::buildSubtree(std::vector<Item>& items, int begin, int end, std::vector<Node>* nodes,
                           std::vector<int>* leaf_of) {
  // Median splits along the widest box side; items are permuted in place.
  struct Task {
    int begin, end, parent;
    bool right;
  };
  std::vector<Task> stack{{begin, end, -1, false}};
  while (!stack.empty()) {
    const Task task = stack.back();
    stack.pop_back();
    const int id = static_cast<int>(nodes->size());
    nodes->push_back(nodeOver(items, task.begin, task.end, task.parent));
    if (task.parent >= 0) {
      Node& up = (*nodes)[task.parent];
      (task.right ? up.right : up.left) = id;
    }
    const int mid = split(items, (*nodes)[id]);
    if (mid < 0) {
      for (int i = task.begin; i < task.end; ++i) (*leaf_of)[i] = id;
      continue;
    }
    stack.push_back({mid, task.end, id, true});
    stack.push_back({task.begin, mid, id, false});
  }
}

KnnTree::Node KnnTree::nodeOver(const std::vector<Item>& items, int begin, int end, int parent) {
  Node node;
  node.begin = begin;
  node.end = end;
  node.parent = parent;
  Eigen::Vector3f lo = items[begin].p, hi = lo;
  for (int i = begin + 1; i < end; ++i) {
    lo = lo.cwiseMin(items[i].p);
    hi = hi.cwiseMax(items[i].p);
  }
  for (int a = 0; a < 3; ++a) {
    node.lo[a] = lo[a];
    node.hi[a] = hi[a];
  }
  return node;
}

int KnnTree::split(std::vector<Item>& items, const Node& node) {
  if (node.end - node.begin <= kLeafSize) return -1;
  int dim = 0;
  float widest = -1.f;
  for (int a = 0; a < 3; ++a) {
    if (node.hi[a] - node.lo[a] > widest) widest = node.hi[a] - node.lo[a], dim = a;
  }
  const int mid = node.begin + (node.end - node.begin) / 2;
  std::nth_element(items.begin() + node.begin, items.begin() + mid, items.begin() + node.end,
                   [dim](const Item& a, const Item& b) { return a.p(dim) < b.p(dim); });
  return mid;
}

KnnTree::KnnTree(const std::vector<Eigen::Vector3f>& points, int threads) {
  const int n = static_cast<int>(points.size());
  std::vector<Item> items(n);
  for (int i = 0; i < n; ++i) items[i] = {points[i], i};
  leaf_of_.assign(n, -1);
  nodes_.reserve(static_cast<std::size_t>(n / (kLeafSize / 2) + 2));
  if (n > 0 && threads > 1 && n >= kMinPointsForParallelBuild) {
    // The root's split here, its two subtrees on two threads, then numbered as the serial
    // build numbers them (root, left subtree, right subtree, each in preorder): the same tree.
    nodes_.push_back(nodeOver(items, 0, n, -1));
    const int mid = split(items, nodes_[0]);
    std::vector<Node> part[2];
    const int range[2][2] = {{0, mid}, {mid, n}};
    parallelFor(2, threads, [&](int k) {
      part[k].reserve(static_cast<std::size_t>((range[k][1] - range[k][0]) / (kLeafSize / 2) + 2));
      buildSubtree(items, range[k][0], range[k][1], &part[k], &leaf_of_);
    });
    const int offset[2] = {1, 1 + static_cast<int>(part[0].size())};
    for (int k = 0; k < 2; ++k) {
      for (Node node : part[k]) {
        node.parent = node.parent < 0 ? 0 : node.parent + offset[k];
        if (node.left >= 0) node.left += offset[k], node.right += offset[k];
        nodes_.push_back(node);
      }
      for (int i = range[k][0]; i < range[k][1]; ++i) leaf_of_[i] += offset[k];
    }
    nodes_[0].left = offset[0];
    nodes_[0].right = offset[1];
  } else if (n > 0) {
    buildSubtree(items, 0, n, &nodes_, &leaf_of_);
  }
  x_.resize(n);
  y_.resize(n);
  z_.resize(n);
  id_.resize(n);
  position_of_.resize(n);
  for (int i = 0; i < n; ++i) {
    x_[i] = items[i].p.x();
    y_[i] = items[i].p.y();
    z_[i] = items[i].p.z();
    id_[i] = items[i].id;
    position_of_[items[i].id] = i;
  }
}

KnnTree KnnTree::restricted(const std::vector<char>& keep) const {
  const int n = static_cast<int>(x_.size());
  if (keep.size() != x_.size())
    throw std::invalid_argument("KnnTree::restricted: one flag per indexed point expected");
  KnnTree out;
  // New input positions: the kept points in input order.
  std::vector<int> rank(static_cast<std::size_t>(n), -1);
  int kept = 0;
  for (int i = 0; i < n; ++i)
    if (keep[static_cast<std::size_t>(i)]) rank[static_cast<std::size_t>(i)] = kept++;
  // New tree positions: the kept points in tree order; before[t] of them precede position t.
  std::vector<int> before(static_cast<std::size_t>(n) + 1, 0);
  out.x_.reserve(static_cast<std::size_t>(kept));
  out.y_.reserve(static_cast<std::size_t>(kept));
  out.z_.reserve(static_cast<std::size_t>(kept));
  out.id_.reserve(static_cast<std::size_t>(kept));
  out.leaf_of_.reserve(static_cast<std::size_t>(kept));
  out.position_of_.assign(static_cast<std::size_t>(kept), -1);
  for (int t = 0; t < n; ++t) {
    const int r = rank[static_cast<std::size_t>(id_[t])];
    before[static_cast<std::size_t>(t) + 1] = before[static_cast<std::size_t>(t)] + (r >= 0);
    if (r < 0) continue;
    out.position_of_[static_cast<std::size_t>(r)] = static_cast<int>(out.x_.size());
    out.x_.push_back(x_[t]);
    out.y_.push_back(y_[t]);
    out.z_.push_back(z_[t]);
    out.id_.push_back(r);
    out.leaf_of_.push_back(leaf_of_[t]);
  }
  if (kept == 0) return KnnTree();
  // The same nodes over the kept ranges; boxes from the points (leaves) and the children
  // (preorder numbering: children after their parent, so a reverse pass sees them first).
  // An empty box is inverted (lo > hi): its distance from any point is infinite.
  out.nodes_ = nodes_;
  const float inf = std::numeric_limits<float>::infinity();
  for (int id = static_cast<int>(out.nodes_.size()) - 1; id >= 0; --id) {
    Node& node = out.nodes_[static_cast<std::size_t>(id)];
    node.begin = before[static_cast<std::size_t>(node.begin)];
    node.end = before[static_cast<std::size_t>(node.end)];
    for (int a = 0; a < 3; ++a) node.lo[a] = inf, node.hi[a] = -inf;
    if (node.left >= 0) {
      for (const int c : {node.left, node.right}) {
        const Node& child = out.nodes_[static_cast<std::size_t>(c)];
        for (int a = 0; a < 3; ++a) {
          node.lo[a] = std::min(node.lo[a], child.lo[a]);
          node.hi[a] = std::max(node.hi[a], child.hi[a]);
        }
      }
      continue;
    }
    for (int i = node.begin; i < node.end; ++i) {
      const float p[3] = {out.x_[i], out.y_[i], out.z_[i]};
      for (int a = 0; a < 3; ++a) {
        node.lo[a] = std::min(node.lo[a], p[a]);
        node.hi[a] = std::max(node.hi[a], p[a]);
      }
    }
  }
  return out;
}

}  // namespace detail
}  // namespace novelty_detection
