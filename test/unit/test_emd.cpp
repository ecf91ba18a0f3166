// EMD between mixtures: hand-computed values, identities, partial matching, and agreement
// with an independent min-cost-flow solver (successive shortest paths) on random cases.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "../../src/mixture/transport_simplex.h"
#include "novelty_detection/mixture/emd.h"

using namespace novelty_detection;

namespace {

// Independent reference: Rubner's partial EMD by successive shortest augmenting paths
// (Bellman-Ford on the residual graph) over source -> rows -> columns -> sink.
double referenceEmd(const Eigen::VectorXd& p, const Eigen::VectorXd& q, const Eigen::MatrixXd& d) {
  const int n = p.size(), m = q.size(), nodes = n + m + 2, s = n + m, t = n + m + 1;
  struct Edge {
    int to;
    double cap, cost;
    int rev;
  };
  std::vector<std::vector<Edge>> g(nodes);
  auto add = [&](int a, int b, double cap, double cost) {
    g[a].push_back({b, cap, cost, static_cast<int>(g[b].size())});
    g[b].push_back({a, 0.0, -cost, static_cast<int>(g[a].size()) - 1});
  };
  for (int i = 0; i < n; ++i) add(s, i, p[i], 0);
  for (int j = 0; j < m; ++j) add(n + j, t, q[j], 0);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < m; ++j) add(i, n + j, 1e18, d(i, j));
  double need = std::min(p.sum(), q.sum()), flow = 0, cost = 0;
  while (need - flow > 1e-12) {
    std::vector<double> dist(nodes, std::numeric_limits<double>::infinity());
    std::vector<int> pv(nodes, -1), pe(nodes, -1);
    dist[s] = 0;
    for (int it = 0; it < nodes; ++it) {
      bool changed = false;
      for (int a = 0; a < nodes; ++a) {
        if (!std::isfinite(dist[a])) continue;
        for (int e = 0; e < static_cast<int>(g[a].size()); ++e) {
          const Edge& ed = g[a][e];
          if (ed.cap > 1e-15 && dist[a] + ed.cost < dist[ed.to] - 1e-15) {
            dist[ed.to] = dist[a] + ed.cost;
            pv[ed.to] = a;
            pe[ed.to] = e;
            changed = true;
          }
        }
      }
      if (!changed) break;
    }
    if (!std::isfinite(dist[t])) break;
    double f = need - flow;
    for (int v = t; v != s; v = pv[v]) f = std::min(f, g[pv[v]][pe[v]].cap);
    for (int v = t; v != s; v = pv[v]) {
      Edge& ed = g[pv[v]][pe[v]];
      ed.cap -= f;
      g[v][ed.rev].cap += f;
    }
    flow += f;
    cost += f * dist[t];
  }
  return flow > 0 ? cost / flow : 0.0;
}

Gaussian gauss(double w, Eigen::Vector3d m, Eigen::Matrix3d c = Eigen::Matrix3d::Identity()) {
  Gaussian g;
  g.weight = w;
  g.mean = m;
  g.cov = c;
  return g;
}

/// A random problem: ground distances in [0, 5), weights in [0, 1) (drawn in that order).
struct Problem {
  Eigen::MatrixXd d;
  Eigen::VectorXd p, q;
};
Problem randomProblem(std::mt19937& rng, int n, int m) {
  std::uniform_real_distribution<double> w(0.0, 1.0);
  Problem x{Eigen::MatrixXd(n, m), Eigen::VectorXd(n), Eigen::VectorXd(m)};
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < m; ++j) x.d(i, j) = 5 * w(rng);
  for (int i = 0; i < n; ++i) x.p[i] = w(rng);
  for (int j = 0; j < m; ++j) x.q[j] = w(rng);
  return x;
}

}  // namespace

TEST(Emd, HandComputedEuclideanCase) {
  // Masses 0.5/0.5 at x=0 and x=1 vs 0.5/0.5 at x=0 and x=3: move 0.5 from x=1 to x=3
  // (cheaper than crossing), EMD = 0.5 * 2 / 1 = 1.
  Gmm a, b;
  a.components = {gauss(0.5, {0, 0, 0}), gauss(0.5, {1, 0, 0})};
  b.components = {gauss(0.5, {0, 0, 0}), gauss(0.5, {3, 0, 0})};
  EXPECT_NEAR(emd(a, b, GroundDistance::kEuclidean), 1.0, 1e-12);
  // Transport 0.7 at (0,0,0) and 0.3 at (0,4,0) to 1.0 at (3,0,0): 0.7*3 + 0.3*5 = 3.6.
  Gmm c, e;
  c.components = {gauss(0.7, {0, 0, 0}), gauss(0.3, {0, 4, 0})};
  e.components = {gauss(1.0, {3, 0, 0})};
  EXPECT_NEAR(emd(c, e, GroundDistance::kEuclidean), 3.6, 1e-12);
}

TEST(Emd, WassersteinGroundDistanceClosedForm) {
  // Isotropic: W2^2 = |dm|^2 + 3 (s_a - s_b)^2 for covariances s^2 I.
  const Gaussian a = gauss(1, {0, 0, 0}, 0.04 * Eigen::Matrix3d::Identity());
  const Gaussian b = gauss(1, {1, 2, 2}, 0.09 * Eigen::Matrix3d::Identity());
  EXPECT_NEAR(gaussianDistance(a, b, GroundDistance::kWasserstein), std::sqrt(9.0 + 3 * 0.01),
              1e-12);
  // Commuting diagonal covariances: sum over axes of (sqrt(a_i) - sqrt(b_i))^2.
  const Gaussian c = gauss(1, {0, 0, 0}, Eigen::Vector3d(1, 4, 9).asDiagonal());
  const Gaussian d = gauss(1, {0, 0, 0}, Eigen::Vector3d(4, 1, 0.25).asDiagonal());
  EXPECT_NEAR(gaussianDistance(c, d, GroundDistance::kWasserstein), std::sqrt(1.0 + 1.0 + 6.25),
              1e-9);
  EXPECT_NEAR(gaussianDistance(c, c, GroundDistance::kWasserstein), 0.0, 1e-7);
  // Rank-deficient (planar) covariances are fine.
  const Gaussian flat = gauss(1, {0, 0, 0}, Eigen::Vector3d(1, 1, 0).asDiagonal());
  EXPECT_TRUE(std::isfinite(gaussianDistance(flat, c, GroundDistance::kWasserstein)));
}

TEST(Emd, ZeroForIdenticalAndSymmetric) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.1, 1.0);
  Gmm a, b;
  for (int k = 0; k < 6; ++k) {
    Eigen::Matrix3d r = Eigen::Matrix3d::Random();
    a.components.push_back(gauss(u(rng), Eigen::Vector3d::Random() * 3, r * r.transpose()));
    r = Eigen::Matrix3d::Random();
    b.components.push_back(gauss(u(rng), Eigen::Vector3d::Random() * 3, r * r.transpose()));
  }
  for (auto type : {GroundDistance::kEuclidean, GroundDistance::kWasserstein}) {
    EXPECT_NEAR(emd(a, a, type), 0.0, 1e-6);
    EXPECT_NEAR(emd(a, b, type), emd(b, a, type), 1e-9);
    EXPECT_GT(emd(a, b, type), 0.1);
  }
}

TEST(Emd, PartialMatchingMovesOnlyTheLighterMass) {
  // 0.4 at x=0 against 0.5 at x=0 and 0.5 at x=10: all of the 0.4 stays put, EMD = 0.
  Eigen::MatrixXd d(1, 2);
  d << 0.0, 10.0;
  EmdSolver solver(d);
  Eigen::VectorXd p(1), q(2);
  p << 0.4;
  q << 0.5, 0.5;
  EmdResult r = solver.solve(p, q, true);
  EXPECT_NEAR(r.distance, 0.0, 1e-12);
  EXPECT_NEAR(r.flow, 0.4, 1e-12);
  EXPECT_NEAR(r.flows(0, 0), 0.4, 1e-12);
  // 0.7 at x=0: 0.5 stays, 0.2 travels 10: EMD = 2 / 0.7.
  p << 0.7;
  r = solver.solve(p, q);
  EXPECT_NEAR(r.distance, 2.0 / 0.7, 1e-9);
  // Heavier first side: the same by symmetry.
  EmdSolver back(d.transpose());
  EXPECT_NEAR(back.solve(q, p).distance, 2.0 / 0.7, 1e-9);
  // Zero mass: nothing moves.
  p << 0.0;
  EXPECT_EQ(solver.solve(p, q).distance, 0.0);
}

TEST(Emd, MatchesIndependentSolverOnRandomCases) {
  std::mt19937 rng(17);
  std::uniform_int_distribution<int> size(1, 9);
  for (int trial = 0; trial < 200; ++trial) {
    const int n = size(rng), m = size(rng);
    auto [d, p, q] = randomProblem(rng, n, m);
    if (trial % 3 == 0) q *= p.sum() / q.sum();  // equal masses too
    const EmdSolver solver(d);
    EXPECT_NEAR(solver.solve(p, q).distance, referenceEmd(p, q, d), 1e-9) << "trial " << trial;
  }
}

// The capacity prices are an optimal dual: their bound equals the cost solved (strong
// duality), and for the same flows with any source emptied it stays below that removal's
// true cost (weak duality), which the greedy selection uses to skip solves.
TEST(Emd, CapacityPricesBoundEveryRemoval) {
  std::mt19937 rng(23);
  std::uniform_int_distribution<int> size(2, 12);
  int tight = 0, removals = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const int n = size(rng), m = size(rng);
    auto [d, p, q] = randomProblem(rng, n, m);
    q *= (trial % 2 ? 1.0 : 1.5) * p.sum() / q.sum();  // equal masses, or spare capacity
    const EmdSolver solver(d);
    const EmdResult full = solver.solve(p, q, true);
    if (p.sum() > q.sum()) {  // equal masses up to round-off, solved transposed: no prices
      EXPECT_EQ(full.capacity_prices.size(), 0);
      continue;
    }
    ASSERT_EQ(full.capacity_prices.size(), m) << "trial " << trial;
    EXPECT_TRUE((full.capacity_prices.array() >= 0.0).all());
    // The prices alone: the same solve without the flows.
    const EmdResult priced = solver.solveWithPrices(p, q);
    EXPECT_EQ(priced.cost, full.cost);
    EXPECT_TRUE(priced.capacity_prices == full.capacity_prices);
    EXPECT_EQ(priced.flows.size(), 0);
    const Eigen::VectorXd alpha =
        (d.rowwise() + full.capacity_prices.transpose()).rowwise().minCoeff();
    const double dual = p.dot(alpha) - q.dot(full.capacity_prices);
    EXPECT_NEAR(dual, full.cost, 1e-9 * std::max(1.0, full.cost)) << "trial " << trial;
    for (int i = 0; i < n; ++i) {
      Eigen::VectorXd t = p;
      t[i] = 0.0;
      if (!(t.sum() > 0)) continue;
      const double exact = solver.solve(t, q).cost;
      const double bound = dual - p[i] * alpha[i];
      EXPECT_LE(bound, exact + 1e-9) << "trial " << trial << " removing " << i;
      ++removals;
      tight += bound > exact - 1e-9;
    }
  }
  // Tight for a good share of removals: the bound is what lets the selection skip solves.
  EXPECT_GT(removals, 600);
  EXPECT_GT(tight, removals / 4);
  // The heavier first mixture is solved transposed: no prices.
  Eigen::MatrixXd d(1, 1);
  d << 1.0;
  EXPECT_EQ(EmdSolver(d)
                .solve(Eigen::VectorXd::Constant(1, 2.0), Eigen::VectorXd::Ones(1), true)
                .capacity_prices.size(),
            0);
}

// The selection's problems: the round's weights with one Gaussian emptied, solved from the
// round's optimal basis. The same optimum as a cold solve (and the independent solver), in a
// few pivots; degenerate weights (empty sources, empty sinks, equal masses, equal costs) too.
TEST(Emd, WarmStartsReachTheSameOptimumInFewPivots) {
  namespace dt = novelty_detection::detail;
  std::mt19937 rng(29);
  std::uniform_real_distribution<double> w(0.0, 1.0);
  std::vector<int> warm_pivots, cold_pivots;
  for (int trial = 0; trial < 40; ++trial) {
    const int n = 10 + trial % 30, m = 8 + (3 * trial) % 25;
    Eigen::MatrixXd d(n, m);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < m; ++j) d(i, j) = trial % 5 == 4 ? std::floor(3 * w(rng)) : 5 * w(rng);
    Eigen::VectorXd p(n), q(m);
    for (int i = 0; i < n; ++i) p[i] = trial % 4 == 1 && i % 3 == 0 ? 0.0 : w(rng);
    for (int j = 0; j < m; ++j) q[j] = trial % 4 == 2 && j % 4 == 0 ? 0.0 : w(rng);
    q *= (trial % 2 ? 1.0 : 1.3) * p.sum() / q.sum();
    q *= 1.0 + 1e-9;  // the lighter side first
    const dt::TransportSolution full = dt::solveTransport(d, p, q, nullptr, true);
    ASSERT_TRUE(full.optimal) << "trial " << trial;
    cold_pivots.push_back(full.pivots);
    EXPECT_NEAR(full.cost / p.sum(), referenceEmd(p, q, d), 1e-9) << "trial " << trial;
    EXPECT_NEAR(full.flows.sum(), p.sum(), 1e-12);
    EXPECT_TRUE((full.flows.array() >= 0.0).all());
    EXPECT_TRUE(((full.flows.colwise().sum().transpose() - q).array() <= 1e-12).all());
    for (int i = 0; i < n; ++i) {
      Eigen::VectorXd t = p;
      t[i] = 0.0;
      const dt::TransportSolution cold = dt::solveTransport(d, t, q, nullptr, false);
      const dt::TransportSolution warm = dt::solveTransport(d, t, q, &full.basis, false);
      ASSERT_TRUE(cold.optimal && warm.optimal) << "trial " << trial << " removing " << i;
      EXPECT_NEAR(warm.cost, cold.cost, 1e-12 * std::max(1.0, cold.cost));
      if (p[i] > 0) warm_pivots.push_back(warm.pivots);
      // The prices of a warm start bound the cost as the cold ones do (strong duality).
      const Eigen::VectorXd alpha = (d.rowwise() + warm.prices.transpose()).rowwise().minCoeff();
      EXPECT_NEAR(t.dot(alpha) - q.dot(warm.prices), warm.cost, 1e-9);
    }
  }
  auto median = [](std::vector<int> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  EXPECT_LE(median(warm_pivots), 3);
  EXPECT_GE(median(cold_pivots), 5 * median(warm_pivots));
  // A basis of other sizes is not a start: the solve is cold.
  Eigen::MatrixXd d = Eigen::MatrixXd::Ones(2, 3);
  const dt::TransportSolution other =
      dt::solveTransport(Eigen::MatrixXd::Ones(3, 3), Eigen::VectorXd::Ones(3),
                         Eigen::VectorXd::Ones(3), nullptr, false);
  const dt::TransportSolution cold =
      dt::solveTransport(d, Eigen::VectorXd::Ones(2), Eigen::VectorXd::Ones(3), nullptr, false);
  const dt::TransportSolution warm = dt::solveTransport(
      d, Eigen::VectorXd::Ones(2), Eigen::VectorXd::Ones(3), &other.basis, false);
  ASSERT_TRUE(cold.optimal && warm.optimal);
  EXPECT_EQ(warm.cost, cold.cost);
  EXPECT_EQ(warm.cost, 2.0);
}

// Through EmdSolver: a solve from another result equals the cold solve, transposed too.
TEST(Emd, SolvesFromAnotherResultEqualColdSolves) {
  std::mt19937 rng(31);
  const int m = 20;
  auto [d, p, q] = randomProblem(rng, 30, m);
  q *= p.sum() / q.sum();
  const EmdSolver solver(d);
  EmdResult round = solver.solve(p, q, true);
  ASSERT_TRUE(round.basis != nullptr);
  for (int k = 0; k < 10; ++k) {
    p[k] = 0.0;  // the greedy selection's rounds
    const EmdResult warm = solver.solve(p, q, true, &round);
    const EmdResult cold = EmdSolver(d).solve(p, q, true);
    EXPECT_NEAR(warm.distance, cold.distance, 1e-12) << "round " << k;
    EXPECT_NEAR(warm.distance, referenceEmd(p, q, d), 1e-9) << "round " << k;
    EXPECT_EQ(warm.capacity_prices.size(), m);
    round = warm;
  }
  // The heavier first side (solved transposed) from a forward result: a cold start.
  Eigen::VectorXd heavy = 2.0 * q;
  const EmdResult back = EmdSolver(d.transpose()).solve(heavy, p, false, &round);
  EXPECT_NEAR(back.distance, referenceEmd(p, heavy, d), 1e-9);
}

TEST(Emd, RejectsBadInput) {
  Eigen::MatrixXd d = Eigen::MatrixXd::Ones(2, 2);
  EmdSolver solver(d);
  EXPECT_THROW(solver.solve(Eigen::VectorXd::Ones(3), Eigen::VectorXd::Ones(2)),
               std::invalid_argument);
  EXPECT_THROW(solver.solve(-Eigen::VectorXd::Ones(2), Eigen::VectorXd::Ones(2)),
               std::invalid_argument);
  d(0, 0) = std::nan("");
  EXPECT_THROW(EmdSolver{d}, std::invalid_argument);
  EXPECT_THROW(parseGroundDistance("kl"), std::invalid_argument);
}
