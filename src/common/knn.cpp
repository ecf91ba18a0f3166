#include "common/knn.h"

#include "common/parallel.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

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

namespace {
/// Inserts d into the ascending list d2[0, k) (entries not yet filled are +infinity),
/// dropping its largest entry, without branches: the j-th entry becomes the larger of the
/// old (j-1)-th and the smaller of the old j-th and d. An insertion's position is
/// unpredictable, and the branches of a shifting insertion were most of a search's time.
template <int K>
inline void insertSorted(float d, float* d2) {
  for (int j = K - 1; j > 0; --j) d2[j] = std::max(d2[j - 1], std::min(d2[j], d));
  d2[0] = std::min(d2[0], d);
}
inline void insertSorted(float d, int k, float* d2) {
  for (int j = k - 1; j > 0; --j) d2[j] = std::max(d2[j - 1], std::min(d2[j], d));
  d2[0] = std::min(d2[0], d);
}
}  // namespace

void KnnTree::search(int node_id, const float* q, int self, int k, float* d2, int* count) const {
  const Node& node = nodes_[node_id];
  if (node.left < 0) {
    for (int i = node.begin; i < node.end; ++i) {
      const float dx = x_[i] - q[0], dy = y_[i] - q[1], dz = z_[i] - q[2];
      const float d = dx * dx + dy * dy + dz * dz;
      if ((*count == k && d >= d2[k - 1]) || i == self) continue;
      if (k == 8) {
        insertSorted<8>(d, d2);
      } else {
        insertSorted(d, k, d2);
      }
      if (*count < k) ++*count;
    }
    return;
  }
  // Children nearer first; a child is entered only while it can still hold a closer point.
  const Node& l = nodes_[node.left];
  const Node& r = nodes_[node.right];
  const float dl = boxDistance2(q, l.lo, l.hi);
  const float dr = boxDistance2(q, r.lo, r.hi);
  const bool left_first = dl <= dr;
  const float d_first = left_first ? dl : dr, d_second = left_first ? dr : dl;
  if (*count < k || d_first < d2[k - 1]) {
    search(left_first ? node.left : node.right, q, self, k, d2, count);
  }
  if (*count < k || d_second < d2[k - 1]) {
    search(left_first ? node.right : node.left, q, self, k, d2, count);
  }
}

void KnnTree::searchFromLeaf(int t, int k, float* d2, int* count) const {
  // Bottom-up: the query's own leaf, then the sibling subtrees on the way to the root,
  // stopping once the ball through the k-th neighbour lies inside the current subtree.
  const float q[3] = {x_[t], y_[t], z_[t]};
  *count = 0;
  std::fill(d2, d2 + k, std::numeric_limits<float>::infinity());
  int node = leaf_of_[t];
  search(node, q, t, k, d2, count);
  while (nodes_[node].parent >= 0) {
    const Node& parent = nodes_[nodes_[node].parent];
    const int sibling = parent.left == node ? parent.right : parent.left;
    if (*count < k || boxDistance2(q, nodes_[sibling].lo, nodes_[sibling].hi) < d2[k - 1]) {
      search(sibling, q, t, k, d2, count);
    }
    node = nodes_[node].parent;
    if (*count == k) {
      float inside = q[0] - parent.lo[0];
      for (int a = 0; a < 3; ++a) {
        inside = std::min({inside, q[a] - parent.lo[a], parent.hi[a] - q[a]});
      }
      if (inside > 0.f && inside * inside >= d2[k - 1]) break;
    }
  }
}

template <class Reduce>
std::vector<double> KnnTree::forEachNeighbourhood(int k, int threads, Reduce reduce) const {
  const int n = static_cast<int>(x_.size());
  std::vector<double> out(n, 0.0);
  k = std::min(k, n - 1);
  if (k <= 0) return out;
  // Blocks of consecutive tree positions: neighbouring queries touch the same memory, and
  // each block writes only its own points' slots.
  constexpr int kBlock = 4096;
  const int blocks = (n + kBlock - 1) / kBlock;
  parallelFor(blocks, threads, [&](int b) {
    std::vector<float> d2(k);
    const int end = std::min(n, (b + 1) * kBlock);
    for (int t = b * kBlock; t < end; ++t) {
      int count = 0;
      searchFromLeaf(t, k, d2.data(), &count);
      out[id_[t]] = reduce(id_[t], d2.data(), count);
    }
  });
  return out;
}

namespace {

/// The mean of the square roots of the ascending squared distances d2[0, count).
double meanOfRoots(const float* d2, int count) {
  double sum = 0.0;
  for (int j = 0; j < count; ++j) sum += std::sqrt(static_cast<double>(d2[j]));
  return sum / count;
}

/// The largest of them as a distance.
double lastRoot(const float* d2, int count) {
  return std::sqrt(static_cast<double>(d2[count - 1]));
}

}  // namespace

std::vector<double> KnnTree::meanNeighbourDistances(int k, int threads,
                                                    std::vector<double>* kth) const {
  if (kth) kth->assign(x_.size(), 0.0);
  return forEachNeighbourhood(k, threads, [kth](int index, const float* d2, int count) {
    if (kth) (*kth)[index] = lastRoot(d2, count);
    return meanOfRoots(d2, count);
  });
}

double KnnTree::meanNeighbourDistance(int index, int k, double* kth) const {
  const int n = static_cast<int>(x_.size());
  k = std::min(k, n - 1);
  if (kth) *kth = 0.0;
  if (k <= 0) return 0.0;
  // On the stack for the usual k (one query per point of a reused neighbourhood statistic).
  constexpr int kStack = 32;
  float stack[kStack];
  std::vector<float> heap(k > kStack ? k : 0);
  float* d2 = k > kStack ? heap.data() : stack;
  int count = 0;
  searchFromLeaf(position_of_[index], k, d2, &count);
  if (kth) *kth = lastRoot(d2, count);
  return meanOfRoots(d2, count);
}

double KnnTree::nearestDistance(const Eigen::Vector3f& p) const {
  if (nodes_.empty()) return std::numeric_limits<double>::infinity();
  const float q[3] = {p.x(), p.y(), p.z()};
  float d2 = std::numeric_limits<float>::infinity();
  int count = 0;
  search(0, q, -1, 1, &d2, &count);  // node 0 is the root; -1: no point is the query itself
  return count ? std::sqrt(static_cast<double>(d2)) : std::numeric_limits<double>::infinity();
}

double KnnTree::kthNearestDistance(const Eigen::Vector3f& p, int k) const {
  if (k < 1 || static_cast<std::size_t>(k) > x_.size()) {
    return std::numeric_limits<double>::infinity();
  }
  const float q[3] = {p.x(), p.y(), p.z()};
  std::vector<float> d2(static_cast<std::size_t>(k), std::numeric_limits<float>::infinity());
  int count = 0;
  search(0, q, -1, k, d2.data(), &count);
  return count == k ? std::sqrt(static_cast<double>(d2[k - 1]))
                    : std::numeric_limits<double>::infinity();
}

template <bool kWhole, class Whole, class Point>
void KnnTree::visitWithin(const Eigen::Vector3f& p, double radius, Whole whole, Point point) const {
  if (nodes_.empty() || !(radius > 0)) return;
  const float q[3] = {p.x(), p.y(), p.z()};
  const float r2 = static_cast<float>(radius * radius);
  // Depth-first, left before right: at most one pending sibling per level.
  int stack[2 * kMaxDepth];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const int id = stack[--top];
    const Node& node = nodes_[id];
    if (!(boxDistance2(q, node.lo, node.hi) < r2)) continue;
    // A box whose farthest corner is within the radius holds only points within it.
    if (kWhole && boxFarDistance2(q, node.lo, node.hi) < r2) {
      whole(id);
      continue;
    }
    if (node.left >= 0) {
      stack[top++] = node.right;
      stack[top++] = node.left;
      continue;
    }
    for (int i = node.begin; i < node.end; ++i) {
      const float dx = x_[i] - q[0], dy = y_[i] - q[1], dz = z_[i] - q[2];
      if (dx * dx + dy * dy + dz * dz < r2) point(i);
    }
  }
}

void KnnTree::within(const Eigen::Vector3f& p, double radius, std::vector<int>* out) const {
  visitWithin<false>(
      p, radius, [](int) {}, [&](int i) { out->push_back(id_[i]); });
}

void KnnTree::Moments::add(double x, double y, double z) {
  x -= o[0], y -= o[1], z -= o[2];
  n += 1.0;
  s[0] += x, s[1] += y, s[2] += z;
  ss[0] += x * x, ss[1] += x * y, ss[2] += x * z, ss[3] += y * y, ss[4] += y * z, ss[5] += z * z;
}

void KnnTree::Moments::add(const Moments& m) {
  n += m.n;
  for (int a = 0; a < 3; ++a) s[a] += m.s[a];
  for (int a = 0; a < 6; ++a) ss[a] += m.ss[a];
}

KnnTree::Moments KnnTree::emptyMoments() const {
  Moments m;
  if (!nodes_.empty())
    for (int a = 0; a < 3; ++a)
      m.o[a] = 0.5 * (static_cast<double>(nodes_[0].lo[a]) + static_cast<double>(nodes_[0].hi[a]));
  return m;
}

void KnnTree::buildMoments() {
  moments_.assign(nodes_.size(), emptyMoments());
  // Preorder numbering: children come after their parent, so a reverse pass sees them first.
  for (int id = static_cast<int>(nodes_.size()) - 1; id >= 0; --id) {
    const Node& node = nodes_[id];
    Moments& m = moments_[id];
    if (node.left >= 0) {
      m.add(moments_[node.left]);
      m.add(moments_[node.right]);
      continue;
    }
    for (int i = node.begin; i < node.end; ++i) m.add(x_[i], y_[i], z_[i]);
  }
}

KnnTree::Moments KnnTree::momentsWithin(const Eigen::Vector3f& p, double radius) const {
  Moments out = emptyMoments();
  const auto point = [&](int i) { out.add(x_[i], y_[i], z_[i]); };
  if (moments_.size() == nodes_.size()) {
    visitWithin<true>(
        p, radius, [&](int node) { out.add(moments_[node]); }, point);
  } else {
    visitWithin<false>(
        p, radius, [](int) {}, point);
  }
  return out;
}

bool KnnTree::anyWithin(const Eigen::Vector3f& p, double radius) const {
  // nearestDistance()'s test: the square root of the float squared distance, in double.
  return radius >= 0.0 &&
         atLeast(p, 1, [radius](float d2) { return std::sqrt(static_cast<double>(d2)) <= radius; });
}

std::vector<double> KnnTree::kthNeighbourDistances(int k, int threads) const {
  return forEachNeighbourhood(k, threads, [](int, const float* d2, int count) {
    return lastRoot(d2, count);  // d2 is sorted ascending
  });
}

}  // namespace detail
}  // namespace novelty_detection
