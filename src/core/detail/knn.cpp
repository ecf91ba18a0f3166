#include "knn.h"

#include <algorithm>
#include <cmath>

namespace novelty_detection {
namespace detail {
namespace {

struct Item {
  Eigen::Vector3f p;
  int id;
};

float boxDistance2(const Eigen::Vector3f& q, const Eigen::Vector3f& lo,
                   const Eigen::Vector3f& hi) {
  const Eigen::Vector3f d = (lo - q).cwiseMax(q - hi).cwiseMax(0.f);
  return d.squaredNorm();
}

}  // namespace

KnnTree::KnnTree(const std::vector<Eigen::Vector3f>& points) {
  const int n = static_cast<int>(points.size());
  std::vector<Item> items(n);
  for (int i = 0; i < n; ++i) items[i] = {points[i], i};
  leaf_of_.assign(n, -1);
  nodes_.reserve(static_cast<std::size_t>(n / (kLeafSize / 2) + 2));
  // Median splits along the widest box side; items are permuted in place.
  pts_.resize(n);
  id_.resize(n);
  if (n == 0) return;
  std::vector<std::pair<int, int>> stack{{0, n}};
  std::vector<int> slot_of_stack{-1};  // node whose child link to fill (-1: root)
  std::vector<char> is_right{0};
  while (!stack.empty()) {
    const auto [begin, end] = stack.back();
    const int parent = slot_of_stack.back();
    const bool right = is_right.back();
    stack.pop_back();
    slot_of_stack.pop_back();
    is_right.pop_back();
    Node node;
    node.begin = begin;
    node.end = end;
    node.lo = node.hi = items[begin].p;
    for (int i = begin + 1; i < end; ++i) {
      node.lo = node.lo.cwiseMin(items[i].p);
      node.hi = node.hi.cwiseMax(items[i].p);
    }
    const int id = static_cast<int>(nodes_.size());
    nodes_.push_back(node);
    if (parent >= 0) (right ? nodes_[parent].right : nodes_[parent].left) = id;
    if (end - begin <= kLeafSize) {
      for (int i = begin; i < end; ++i) leaf_of_[i] = id;
      continue;
    }
    int dim = 0;
    (node.hi - node.lo).maxCoeff(&dim);
    const int mid = begin + (end - begin) / 2;
    std::nth_element(items.begin() + begin, items.begin() + mid, items.begin() + end,
                     [dim](const Item& a, const Item& b) { return a.p(dim) < b.p(dim); });
    stack.push_back({mid, end});
    slot_of_stack.push_back(id);
    is_right.push_back(1);
    stack.push_back({begin, mid});
    slot_of_stack.push_back(id);
    is_right.push_back(0);
  }
  for (int i = 0; i < n; ++i) {
    pts_[i] = items[i].p;
    id_[i] = items[i].id;
  }
}

void KnnTree::search(int node_id, const Eigen::Vector3f& q, int self, int k, float* d2,
                     int* who, int* count, int skip_node) const {
  const Node& node = nodes_[node_id];
  if (*count == k && boxDistance2(q, node.lo, node.hi) >= d2[k - 1]) return;
  if (node.left < 0) {
    if (node_id == skip_node) return;
    for (int i = node.begin; i < node.end; ++i) {
      if (i == self) continue;
      const float d = (pts_[i] - q).squaredNorm();
      if (*count == k && d >= d2[k - 1]) continue;
      int j = *count < k ? (*count)++ : k - 1;  // insertion into the sorted list
      while (j > 0 && d2[j - 1] > d) {
        d2[j] = d2[j - 1];
        who[j] = who[j - 1];
        --j;
      }
      d2[j] = d;
      who[j] = i;
    }
    return;
  }
  const float dl = boxDistance2(q, nodes_[node.left].lo, nodes_[node.left].hi);
  const float dr = boxDistance2(q, nodes_[node.right].lo, nodes_[node.right].hi);
  if (dl <= dr) {
    search(node.left, q, self, k, d2, who, count, skip_node);
    search(node.right, q, self, k, d2, who, count, skip_node);
  } else {
    search(node.right, q, self, k, d2, who, count, skip_node);
    search(node.left, q, self, k, d2, who, count, skip_node);
  }
}

std::vector<double> KnnTree::meanNeighbourDistances(int k, std::vector<int>* neighbours) const {
  const int n = static_cast<int>(pts_.size());
  std::vector<double> out(n, 0.0);
  k = std::min(k, n - 1);
  if (neighbours) neighbours->assign(static_cast<std::size_t>(std::max(k, 0)) * n, -1);
  if (k <= 0) return out;
  std::vector<float> d2(k);
  std::vector<int> who(k);
  for (int t = 0; t < n; ++t) {  // tree order: neighbouring queries touch the same memory
    int count = 0;
    const int leaf = leaf_of_[t];
    search(leaf, pts_[t], t, k, d2.data(), who.data(), &count, -1);  // own leaf: tight bound
    search(0, pts_[t], t, k, d2.data(), who.data(), &count, leaf);
    double sum = 0.0;
    for (int j = 0; j < count; ++j) sum += std::sqrt(static_cast<double>(d2[j]));
    out[id_[t]] = sum / count;
    if (neighbours) {
      int* row = neighbours->data() + static_cast<std::size_t>(id_[t]) * k;
      for (int j = 0; j < count; ++j) row[j] = id_[who[j]];
    }
  }
  return out;
}

}  // namespace detail
}  // namespace novelty_detection
