// Greedy novelty selection (Algorithm 1): finds exactly the added Gaussians, wherever they
// sit in the mixture; the stated stop rule; pruning gives the same answer as brute force, on
// one thread or several.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "novelty_detection/mixture/novelty_selection.h"

using namespace novelty_detection;

namespace {

Gmm randomScene(int k, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-5.0, 5.0), s(0.01, 0.2);
  Gmm g;
  for (int i = 0; i < k; ++i) {
    Gaussian c;
    c.weight = 1.0 / k;
    c.mean = Eigen::Vector3d(u(rng), u(rng), 0.2 * u(rng));
    c.cov = Eigen::Vector3d(s(rng), s(rng), 0.001).asDiagonal();
    g.components.push_back(c);
  }
  return g;
}

// The reference plus new Gaussians inserted at `positions` (each of weight w), the old ones
// slightly perturbed (sampling noise) and reweighted so that weights sum to 1.
Gmm withInsertions(const Gmm& ref, const std::vector<int>& positions, double w, unsigned seed,
                   double jitter_m = 0.005) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, jitter_m);
  Gmm cur;
  for (auto c : ref.components) {
    c.weight *= 1.0 - w * positions.size();
    c.mean += Eigen::Vector3d(n(rng), n(rng), n(rng));
    cur.components.push_back(c);
  }
  for (std::size_t k = 0; k < positions.size(); ++k) {
    Gaussian obj;
    obj.weight = w;
    obj.mean = Eigen::Vector3d(1.0 + 1.5 * k, -1.0, 0.5);  // off every surface
    obj.cov = Eigen::Vector3d(0.02, 0.02, 0.05).asDiagonal();
    cur.components.insert(cur.components.begin() + positions[k], obj);
  }
  return cur;
}

SelectionParams defaults() {
  SelectionParams p;
  p.u_th = 0.05;  // well above the 5 mm jitter, well below an object's contribution
  return p;
}

}  // namespace

TEST(NoveltySelection, FindsTheAddedGaussianWhereverItSits) {
  const Gmm ref = randomScene(12, 1);
  for (int pos : {0, 5, 12}) {  // first, middle, LAST
    const Gmm cur = withInsertions(ref, {pos}, 0.08, 2);
    const SelectionResult r = GreedyNoveltySelector(defaults()).select(cur, ref);
    ASSERT_EQ(r.novel.size(), 1u) << "insert at " << pos;
    EXPECT_EQ(r.novel[0], pos);
    EXPECT_GT(r.emd_before, 5 * r.emd_after);
    EXPECT_NEAR(r.emd_before - r.emd_after, r.decrease[0], 1e-12);
  }
}

TEST(NoveltySelection, FindsSeveralAddedGaussians) {
  const Gmm ref = randomScene(15, 3);
  const Gmm cur = withInsertions(ref, {2, 9, 17}, 0.05, 4);
  const SelectionResult r = GreedyNoveltySelector(defaults()).select(cur, ref);
  std::vector<int> got = r.novel;
  std::sort(got.begin(), got.end());
  EXPECT_EQ(got, (std::vector<int>{2, 9, 17}));
  // The EMD falls at every accepted step.
  for (std::size_t t = 1; t < r.emd_trace.size(); ++t)
    EXPECT_LT(r.emd_trace[t], r.emd_trace[t - 1]);
}

TEST(NoveltySelection, NothingAddedNothingSelected) {
  const Gmm ref = randomScene(10, 5);
  const Gmm cur = withInsertions(ref, {}, 0.0, 6);
  EXPECT_TRUE(GreedyNoveltySelector(defaults()).select(cur, ref).novel.empty());
  // Identical mixtures: EMD 0, the rule stops at once even without u_th.
  SelectionParams p = defaults();
  p.u_th = 0.0;
  const SelectionResult r = GreedyNoveltySelector(p).select(ref, ref);
  EXPECT_TRUE(r.novel.empty());
  EXPECT_NEAR(r.emd_before, 0.0, 1e-6);  // sqrt of a round-off Bures term
}

TEST(NoveltySelection, StopRuleRelativeDecreaseAndCap) {
  const Gmm ref = randomScene(10, 7);
  const Gmm cur = withInsertions(ref, {3, 10}, 0.05, 8);
  SelectionParams p = defaults();
  p.max_novel_gaussians = 1;
  EXPECT_EQ(GreedyNoveltySelector(p).select(cur, ref).novel.size(), 1u);
  // A demanded decrease above what any removal gives: nothing is accepted.
  p = defaults();
  p.min_relative_decrease = 0.99;
  EXPECT_TRUE(GreedyNoveltySelector(p).select(cur, ref).novel.empty());
  // u_th above the initial EMD: no novelty by the threshold rule.
  p = defaults();
  p.u_th = 100.0;
  EXPECT_TRUE(GreedyNoveltySelector(p).select(cur, ref).novel.empty());
}

TEST(NoveltySelection, SingleGaussianCanBeRemoved) {
  // Theta = one Gaussian far from Gamma: removing it (the last and only one) empties Theta.
  Gmm ref = randomScene(3, 9), cur;
  Gaussian far;
  far.weight = 1.0;
  far.mean = {50, 50, 50};
  cur.components = {far};
  const SelectionResult r = GreedyNoveltySelector(defaults()).select(cur, ref);
  ASSERT_EQ(r.novel.size(), 1u);
  EXPECT_EQ(r.emd_after, 0.0);
}

TEST(NoveltySelection, PruningAgreesWithBruteForce) {
  // Brute force: every candidate solved exactly each round, same stop rule.
  std::mt19937 rng(21);
  for (int trial = 0; trial < 20; ++trial) {
    const Gmm ref = randomScene(8 + trial % 5, 100 + trial);
    const Gmm cur = randomScene(6 + trial % 7, 200 + trial);
    SelectionParams p;
    p.min_relative_decrease = 0.02;
    p.ground_distance = trial % 2 ? "euclidean" : "wasserstein";
    const SelectionResult fast = GreedyNoveltySelector(p).select(cur, ref);
    // The candidates dealt to lanes on several threads: the same choices, bit for bit (a
    // lane may skip more or fewer candidates than the serial order does).
    for (int threads : {2, 3}) {
      const SelectionResult batched = GreedyNoveltySelector(p).setThreads(threads).select(cur, ref);
      EXPECT_EQ(batched.novel, fast.novel) << "trial " << trial << " threads " << threads;
      EXPECT_EQ(batched.emd_trace, fast.emd_trace) << "trial " << trial;
      if (!fast.novel.empty()) EXPECT_GT(batched.exact_evaluations, 0);
    }

    const Eigen::MatrixXd d =
        groundDistanceMatrix(cur, ref, parseGroundDistance(p.ground_distance));
    Eigen::VectorXd w(cur.size()), q(ref.size());
    for (std::size_t i = 0; i < cur.size(); ++i) w[i] = cur.components[i].weight;
    for (std::size_t j = 0; j < ref.size(); ++j) q[j] = ref.components[j].weight;
    EmdSolver solver(d);
    double current = solver.solve(w, q).distance;
    std::vector<int> brute;
    while (static_cast<int>(brute.size()) < p.max_novel_gaussians) {
      double best = 1e300;
      int best_i = -1;
      for (int i = 0; i < w.size(); ++i) {
        if (w[i] <= 0) continue;
        Eigen::VectorXd t = w;
        t[i] = 0;
        const double v = t.sum() > 0 ? solver.solve(t, q).distance : 0.0;
        if (v < best - 1e-12) best = v, best_i = i;
      }
      if (best_i < 0 || !(current - best >= p.min_relative_decrease * current) ||
          !(current - best > 0))
        break;
      w[best_i] = 0;
      brute.push_back(best_i);
      current = best;
    }
    EXPECT_EQ(fast.novel, brute) << "trial " << trial;
    EXPECT_NEAR(fast.emd_after, current, 1e-9);
  }
}
