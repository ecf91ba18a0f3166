#include "mixture/transport_simplex.h"

#include <algorithm>
#include <limits>

namespace novelty_detection {
namespace detail {
namespace {

/// Pivots allowed per node of the network before the solve is given up (a dual simplex can
/// cycle on degenerate pivots; the caller then solves the problem another way).
constexpr int kMaxPivotsPerNode = 20;

}  // namespace

TransportSolution solveTransport(const Eigen::MatrixXd& c, const Eigen::VectorXd& s,
                                 const Eigen::VectorXd& t, const TransportBasis* start,
                                 bool with_flows) {
  const int n = static_cast<int>(c.rows()), m = static_cast<int>(c.cols());
  const int nodes = n + 1 + m, tree = n + m;  // sources 0..n (n: slack), then the sinks
  TransportSolution out;
  if (m == 0 || s.size() != n || t.size() != m) return out;
  auto cost = [&](int i, int j) { return i < n ? c(i, j) : 0.0; };
  std::vector<double> b(static_cast<std::size_t>(nodes));
  double supply = 0.0, capacity = 0.0;
  for (int i = 0; i < n; ++i) supply += (b[i] = s[i]);
  for (int j = 0; j < m; ++j) capacity += t[j], b[n + 1 + j] = -t[j];
  b[n] = std::max(0.0, capacity - supply);

  TransportBasis& basis = out.basis;
  basis.n = n;
  basis.m = m;
  if (start && start->n == n && start->m == m && static_cast<int>(start->arcs.size()) == tree) {
    basis.arcs = start->arcs;
  } else {
    for (int j = 0; j < m; ++j) basis.arcs.emplace_back(n, j);
    for (int i = 0; i < n; ++i) {
      int cheapest = 0;
      for (int j = 1; j < m; ++j)
        if (c(i, j) < c(i, cheapest)) cheapest = j;
      basis.arcs.emplace_back(i, cheapest);
    }
  }
  std::vector<std::pair<int, int>>& arcs = basis.arcs;

  // The tree, rebuilt per pivot (n + m is small: tens of Gaussians a side).
  std::vector<int> head(static_cast<std::size_t>(nodes)), next(2 * tree), to(2 * tree),
      arc_of(2 * tree);
  std::vector<int> parent(static_cast<std::size_t>(nodes)), parent_arc(nodes), order(nodes);
  std::vector<double> potential(static_cast<std::size_t>(nodes)), net(nodes), flow(tree);
  std::vector<char> below(static_cast<std::size_t>(nodes));
  std::vector<int> k_sinks;
  const double tolerance = 1e-12 * capacity;
  const int max_pivots = kMaxPivotsPerNode * nodes;
  for (;;) {
    std::fill(head.begin(), head.end(), -1);
    for (int a = 0, e = 0; a < tree; ++a) {
      const int u = arcs[a].first, v = n + 1 + arcs[a].second;
      to[e] = v, arc_of[e] = a, next[e] = head[u], head[u] = e++;
      to[e] = u, arc_of[e] = a, next[e] = head[v], head[v] = e++;
    }
    // Breadth first from the slack source: parents before children.
    std::fill(parent.begin(), parent.end(), -2);
    int reached = 0;
    order[reached++] = n;
    parent[n] = -1;
    parent_arc[n] = -1;
    for (int h = 0; h < reached; ++h) {
      const int x = order[h];
      for (int e = head[x]; e >= 0; e = next[e]) {
        const int y = to[e];
        if (parent[y] != -2) continue;
        parent[y] = x;
        parent_arc[y] = arc_of[e];
        order[reached++] = y;
      }
    }
    if (reached != nodes) return out;  // not a spanning tree
    potential[n] = 0.0;
    for (int h = 1; h < nodes; ++h) {
      const int x = order[h];
      const auto& arc = arcs[parent_arc[x]];
      potential[x] = cost(arc.first, arc.second) - potential[parent[x]];
    }
    // Each tree arc carries what the subtree below it supplies (a source below) or needs
    // (a sink below).
    std::copy(b.begin(), b.end(), net.begin());
    for (int h = nodes - 1; h >= 1; --h) {
      const int x = order[h];
      flow[parent_arc[x]] = x <= n ? net[x] : -net[x];
      net[parent[x]] += net[x];
    }
    int leave = -1;
    double most = -tolerance;
    for (int a = 0; a < tree; ++a)
      if (flow[a] < most) most = flow[a], leave = a;
    if (leave < 0) break;
    if (out.pivots >= max_pivots) return out;
    // The side K of the leaving arc's source needs what it cannot get through the arc: the
    // cheapest arc from a source on the other side L into a sink of K enters.
    const int source = arcs[leave].first;
    const int child = parent_arc[source] == leave ? source : n + 1 + arcs[leave].second;
    std::fill(below.begin(), below.end(), 0);
    below[child] = 1;
    for (int h = 1; h < nodes; ++h)
      if (order[h] != child && below[parent[order[h]]]) below[order[h]] = 1;
    const char k_side = below[source];
    k_sinks.clear();
    for (int j = 0; j < m; ++j)
      if (below[n + 1 + j] == k_side) k_sinks.push_back(j);
    double least = std::numeric_limits<double>::infinity();
    int enter_i = -1, enter_j = -1;
    for (int i = 0; i <= n; ++i) {
      if (below[i] == k_side) continue;
      for (int j : k_sinks) {
        const double reduced = cost(i, j) - potential[i] - potential[n + 1 + j];
        if (reduced < least) least = reduced, enter_i = i, enter_j = j;
      }
    }
    if (enter_i < 0) return out;  // infeasible: cannot happen with sum s <= sum t
    arcs[leave] = {enter_i, enter_j};
    ++out.pivots;
  }
  out.optimal = true;
  if (with_flows) out.flows = Eigen::MatrixXd::Zero(n, m);
  for (int a = 0; a < tree; ++a) {
    const auto [i, j] = arcs[a];
    if (i == n) continue;
    const double x = std::max(0.0, flow[a]);
    out.cost += c(i, j) * x;
    if (with_flows) out.flows(i, j) = x;
  }
  out.prices.resize(m);
  for (int j = 0; j < m; ++j) out.prices[j] = std::max(0.0, -potential[n + 1 + j]);
  return out;
}

}  // namespace detail
}  // namespace novelty_detection
