// The k-d tree's queries (knn.h); its construction is in knn_build.cpp.
#include "common/knn.h"

#include "common/parallel.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace novelty_detection {
namespace detail {
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
/// The largest float t with sqrt(t) <= radius in double (radius >= 0; sqrt is monotonic): a
/// float squared distance d2 passes sqrt(d2) <= radius exactly when d2 <= t.
float squaredBoundOf(double radius) {
  const float inf = std::numeric_limits<float>::infinity();
  if (!std::isfinite(radius)) return inf;
  float t =
      static_cast<float>(std::min(radius * radius, double{std::numeric_limits<float>::max()}));
  while (t > 0.f && !(std::sqrt(static_cast<double>(t)) <= radius)) t = std::nextafter(t, 0.f);
  while (std::sqrt(static_cast<double>(std::nextafter(t, inf))) <= radius)
    t = std::nextafter(t, inf);
  return t;
}

}  // namespace

void KnnTree::search(int node_id, const float* q, int self, int k, float* d2, int* count) const {
  const Node& node = nodes_[node_id];
  if (node.left < 0) {
    // Only the points below the k-th distance as it stood on entering the leaf are looked
    // at, in order: most points of a leaf other than the query's own are farther.
    float dd[kLeafSize];
    const bool full = *count == k;
    const float bound = d2[k - 1];
    unsigned below =
        scanLeaf(node, q, dd, [full, bound](float d) { return !(full && d >= bound); });
    if (self >= node.begin && self < node.end) below &= ~(1u << (self - node.begin));
    while (below != 0) {
      const int j = __builtin_ctz(below);
      below &= below - 1;
      const float d = dd[j];
      if (*count == k && d >= d2[k - 1]) continue;
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
    float dd[kLeafSize];
    for (unsigned bits = scanLeaf(node, q, dd, [r2](float d) { return d < r2; }); bits != 0;
         bits &= bits - 1)
      point(node.begin + __builtin_ctz(bits));
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
  // nearestDistance()'s test: the square root of the float squared distance, in double,
  // as the float bound squaredBoundOf(radius), kept while the thread asks with one radius
  // (the distance tests of a stage ask a run of queries with one).
  if (!(radius >= 0.0)) return false;
  thread_local double last_radius = -1.0;
  thread_local float last_bound = 0.f;
  if (radius != last_radius) last_radius = radius, last_bound = squaredBoundOf(radius);
  const float t = last_bound;
  const auto close = [t](float d2) { return d2 <= t; };
  // The calling thread's last hit on this tree (a tree since freed may share the address:
  // any leaf is only a first guess, the answer is the search's).
  thread_local const KnnTree* last_tree = nullptr;
  thread_local int last_leaf = -1;
  if (last_tree == this && last_leaf >= 0 && static_cast<std::size_t>(last_leaf) < nodes_.size() &&
      nodes_[last_leaf].left < 0) {
    const float q[3] = {p.x(), p.y(), p.z()};
    float dd[kLeafSize];
    if (scanLeaf(nodes_[last_leaf], q, dd, close) != 0) return true;
  }
  int leaf = -1;
  if (!atLeast(p, 1, close, &leaf)) return false;
  last_tree = this;
  last_leaf = leaf;
  return true;
}

std::vector<double> KnnTree::kthNeighbourDistances(int k, int threads) const {
  return forEachNeighbourhood(k, threads, [](int, const float* d2, int count) {
    return lastRoot(d2, count);  // d2 is sorted ascending
  });
}

}  // namespace detail
}  // namespace novelty_detection
