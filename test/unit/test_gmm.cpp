// EM recovers a sampled mixture; regularisation, weights, determinism and degenerate input.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <vector>

#include "novelty_detection/mixture/gmm.h"

using namespace novelty_detection;

namespace {

// Samples a 3-component mixture with known parameters (seeded).
WeightedPoints sampleMixture(const Gmm& truth, int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::discrete_distribution<int> pick(
      {truth.components[0].weight, truth.components[1].weight, truth.components[2].weight});
  std::normal_distribution<double> g(0.0, 1.0);
  WeightedPoints d;
  d.points.resize(3, n);
  for (int i = 0; i < n; ++i) {
    const Gaussian& c = truth.components[pick(rng)];
    const Eigen::Matrix3d l = c.cov.llt().matrixL();
    d.points.col(i) = c.mean + l * Eigen::Vector3d(g(rng), g(rng), g(rng));
  }
  return d;
}

Gmm truthMixture() {
  Gmm t;
  Gaussian a, b, c;
  a.weight = 0.5;
  a.mean = {0, 0, 0};
  a.cov = Eigen::Vector3d(0.04, 0.01, 0.0025).asDiagonal();
  b.weight = 0.3;
  b.mean = {2.0, 1.0, 0.5};
  b.cov << 0.02, 0.005, 0, 0.005, 0.03, 0, 0, 0, 0.01;
  c.weight = 0.2;
  c.mean = {-1.5, 2.0, 1.0};
  c.cov = Eigen::Vector3d(0.01, 0.01, 0.05).asDiagonal();
  t.components = {a, b, c};
  return t;
}

// Matches each true component to its nearest fitted mean.
const Gaussian& nearest(const Gmm& g, const Eigen::Vector3d& m) {
  std::size_t best = 0;
  for (std::size_t k = 1; k < g.size(); ++k)
    if ((g.components[k].mean - m).norm() < (g.components[best].mean - m).norm()) best = k;
  return g.components[best];
}

}  // namespace

TEST(Gmm, EmRecoversSampledThreeComponentMixture) {
  const Gmm truth = truthMixture();
  const WeightedPoints data = sampleMixture(truth, 6000, 7);
  GmmParams p;
  p.min_variance_m2 = 1e-6;
  p.tolerance = 1e-7;
  p.max_iterations = 200;
  EmStats st;
  const Gmm fit = GmmFitter(p).fit(data, 3, &st);
  ASSERT_EQ(fit.size(), 3u);
  double wsum = 0;
  for (const auto& g : fit.components) wsum += g.weight;
  EXPECT_NEAR(wsum, 1.0, 1e-12);
  for (const auto& t : truth.components) {
    const Gaussian& f = nearest(fit, t.mean);
    EXPECT_LT((f.mean - t.mean).norm(), 0.02);
    EXPECT_NEAR(f.weight, t.weight, 0.02);
    EXPECT_LT((f.cov - t.cov).norm(), 0.01);
  }
  EXPECT_TRUE(st.converged);
  EXPECT_LT(st.iterations, 200);
}

TEST(Gmm, WeightedPointsEqualRepeatedPoints) {
  // A point of weight 3 must act like three copies of it.
  const WeightedPoints base = sampleMixture(truthMixture(), 300, 3);
  WeightedPoints weighted = base, repeated;
  weighted.weights = Eigen::VectorXd::Ones(base.size());
  weighted.weights.head(100).setConstant(3.0);
  repeated.points.resize(3, base.size() + 200);
  repeated.points << base.points, base.points.leftCols(100), base.points.leftCols(100);
  GmmParams p;
  GmmFitter f(p);
  const Gmm init = f.initFromLabels(weighted, f.kmeansLabels(weighted, 3), 3);
  const Gmm a = f.fitFrom(weighted, init);
  const Gmm b = f.fitFrom(repeated, init);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_NEAR(a.components[k].weight, b.components[k].weight, 1e-9);
    EXPECT_LT((a.components[k].mean - b.components[k].mean).norm(), 1e-9);
    EXPECT_LT((a.components[k].cov - b.components[k].cov).norm(), 1e-9);
  }
}

TEST(Gmm, PlanarAndCollinearClustersStayPositiveDefinite) {
  WeightedPoints d;
  d.points.resize(3, 400);
  for (int i = 0; i < 200; ++i) d.points.col(i) << 0.01 * (i % 20), 0.01 * (i / 20), 0.0;
  for (int i = 200; i < 400; ++i) d.points.col(i) << 5.0, 5.0, 0.005 * i;  // a line
  GmmParams p;
  const Gmm g = GmmFitter(p).fit(d, 2);
  ASSERT_EQ(g.size(), 2u);
  for (const auto& c : g.components) {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(c.cov);
    EXPECT_GE(es.eigenvalues().minCoeff(), p.min_variance_m2 * 0.999);
    EXPECT_TRUE(c.mean.allFinite());
  }
}

TEST(Gmm, DeterministicForASeed) {
  const WeightedPoints data = sampleMixture(truthMixture(), 1000, 11);
  GmmParams p;
  const Gmm a = GmmFitter(p).fit(data, 5), b = GmmFitter(p).fit(data, 5);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) EXPECT_EQ(a.components[k].mean, b.components[k].mean);
}

TEST(Gmm, ComponentRuleAndDegenerateInput) {
  GmmParams p;
  p.points_per_component = 100;
  p.max_components = 8;
  GmmFitter f(p);
  WeightedPoints d;
  d.points = Eigen::Matrix3Xd::Random(3, 250);
  EXPECT_EQ(f.numComponents(d), 3);
  d.points = Eigen::Matrix3Xd::Random(3, 5000);
  EXPECT_EQ(f.numComponents(d), 8);
  // Fewer points than components: never more Gaussians than points, no NaN.
  WeightedPoints two;
  two.points = Eigen::Matrix3Xd::Random(3, 2);
  const Gmm g = f.fit(two, 10);
  EXPECT_LE(g.size(), 2u);
  for (const auto& c : g.components) EXPECT_TRUE(c.cov.allFinite() && c.mean.allFinite());
  // A single repeated point, and an empty set.
  WeightedPoints same;
  same.points = Eigen::Matrix3Xd::Ones(3, 30);
  const Gmm s = f.fit(same, 4);
  ASSERT_EQ(s.size(), 1u);
  EXPECT_NEAR(s.components[0].weight, 1.0, 1e-12);
  EXPECT_TRUE(f.fit(WeightedPoints{}).empty());
  // Bad input is refused clearly.
  WeightedPoints bad = two;
  bad.points(0, 0) = std::nan("");
  EXPECT_THROW(f.fit(bad, 1), std::invalid_argument);
}

TEST(Gmm, ResponsibilitiesSumToOneFarFromEveryComponent) {
  Gmm g = truthMixture();
  Eigen::Matrix3Xd x(3, 2);
  x.col(0) << 1e3, 1e3, 1e3;  // underflows every density: log-sum-exp keeps it finite
  x.col(1) << 0, 0, 0;
  const Eigen::MatrixXd r = responsibilities(g, x);
  EXPECT_TRUE(r.allFinite());
  EXPECT_NEAR(r.col(0).sum(), 1.0, 1e-12);
  EXPECT_NEAR(r.col(1).sum(), 1.0, 1e-12);
  EXPECT_GT(r(0, 1), 0.99);
}

// Responsibilities and log-likelihoods against the densities summed directly: a Gaussian
// far from a point (log-ratio below -50 to the nearest) gets exactly 0, the others their
// share, and the log-likelihood is the log of the mixture's density.
TEST(Gmm, ResponsibilitiesMatchDirectDensities) {
  Gmm g = truthMixture();
  Gaussian far;
  far.weight = 0.2;
  far.mean = Eigen::Vector3d(40, 0, 0);
  far.cov = 0.01 * Eigen::Matrix3d::Identity();
  g.components.push_back(far);
  for (auto& c : g.components) c.weight /= 1.2;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.4, 0.4);
  Eigen::Matrix3Xd x(3, 200);  // near the three near Gaussians, where their densities overlap
  for (int i = 0; i < x.cols(); ++i)
    x.col(i) = g.components[i % 3].mean + Eigen::Vector3d(u(rng), u(rng), u(rng));
  Eigen::VectorXd ll;
  const Eigen::MatrixXd r = responsibilities(g, x, &ll);
  for (int i = 0; i < x.cols(); ++i) {
    std::vector<double> p;
    for (const auto& c : g.components) {
      const Eigen::Vector3d d = x.col(i) - c.mean;
      p.push_back(c.weight * std::exp(-0.5 * d.dot(c.cov.inverse() * d)) /
                  std::sqrt(std::pow(2 * M_PI, 3) * c.cov.determinant()));
    }
    const double total = std::accumulate(p.begin(), p.end(), 0.0);
    ASSERT_GT(total, 0.0);
    EXPECT_NEAR(ll[i], std::log(total), 1e-9) << "point " << i;
    for (std::size_t k = 0; k + 1 < p.size(); ++k) EXPECT_NEAR(r(k, i), p[k] / total, 1e-12);
    EXPECT_EQ(r(g.size() - 1, i), 0.0) << "point " << i;
    EXPECT_DOUBLE_EQ(r.col(i).sum(), 1.0);
  }
}

// The E-step runs over blocks of points on several threads: responsibilities,
// log-likelihoods and whole EM fits are the same, bit for bit, for any thread count, and
// the blocks join where they should (points on both sides of a block boundary match the
// one-thread values).
TEST(Gmm, EStepIsTheSameOnAnyNumberOfThreads) {
  const Gmm truth = truthMixture();
  const WeightedPoints data = sampleMixture(truth, 5000, 17);  // five blocks
  Eigen::VectorXd ll1;
  const Eigen::MatrixXd r1 = responsibilities(truth, data.points, &ll1, 1);
  ASSERT_EQ(r1.cols(), 5000);
  for (int threads : {2, 3}) {
    Eigen::VectorXd ll;
    const Eigen::MatrixXd r = responsibilities(truth, data.points, &ll, threads);
    EXPECT_TRUE(r == r1) << threads << " threads";
    EXPECT_TRUE(ll == ll1) << threads << " threads";
    EXPECT_TRUE(logWeightedDensities(truth, data.points, threads) ==
                logWeightedDensities(truth, data.points, 1));
  }
  // A point alone gets the value it gets among the others.
  for (int i : {0, 1023, 1024, 4999}) {
    Eigen::VectorXd ll;
    const Eigen::MatrixXd r = responsibilities(truth, data.points.col(i), &ll, 2);
    EXPECT_NEAR(ll[0], ll1[i], 1e-12) << "point " << i;
    EXPECT_NEAR((r.col(0) - r1.col(i)).cwiseAbs().maxCoeff(), 0.0, 1e-12) << "point " << i;
  }
  GmmParams params;
  GmmFitter one(params), three(params);
  three.setThreads(3);
  const Gmm a = one.fit(data, 3), b = three.fit(data, 3);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a.components[k].weight, b.components[k].weight);
    EXPECT_TRUE(a.components[k].mean == b.components[k].mean);
    EXPECT_TRUE(a.components[k].cov == b.components[k].cov);
  }
  const Gmm wa = one.fitWeights(data, truth), wb = three.fitWeights(data, truth);
  for (std::size_t k = 0; k < wa.size(); ++k)
    EXPECT_EQ(wa.components[k].weight, wb.components[k].weight);
}

// Point by point, without the K x N matrix: each point's responsibilities and
// log-likelihood are responsibilities()'s column, bit for bit, on any number of threads,
// every point visited once.
TEST(Gmm, ResponsibilitiesPointByPointAreTheMatrixColumns) {
  Gmm g = truthMixture();
  Gaussian far;  // a Gaussian whose responsibilities are exactly 0 for every sample
  far.weight = 0.1;
  far.mean = Eigen::Vector3d(40, 0, 0);
  far.cov = 0.01 * Eigen::Matrix3d::Identity();
  g.components.push_back(far);
  const WeightedPoints data = sampleMixture(truthMixture(), 5000, 23);  // five blocks
  Eigen::VectorXd ll;
  const Eigen::MatrixXd r = responsibilities(g, data.points, &ll, 1);
  for (int threads : {1, 2, 3}) {
    Eigen::MatrixXd seen = Eigen::MatrixXd::Constant(r.rows(), r.cols(), -1.0);
    Eigen::VectorXd seen_ll = Eigen::VectorXd::Constant(ll.size(), 1.0);
    std::vector<int> visits(static_cast<std::size_t>(r.cols()), 0);
    forEachResponsibility(g, data.points, threads,
                          [&](Eigen::Index n, const double* column, double lse) {
                            seen.col(n) = Eigen::Map<const Eigen::VectorXd>(column, r.rows());
                            seen_ll[n] = lse;
                            ++visits[static_cast<std::size_t>(n)];
                          });
    EXPECT_TRUE(seen == r) << threads << " threads";
    EXPECT_TRUE(seen_ll == ll) << threads << " threads";
    EXPECT_EQ(std::count(visits.begin(), visits.end(), 1), r.cols()) << threads << " threads";
    EXPECT_EQ(seen.row(g.size() - 1).maxCoeff(), 0.0);
  }
  int calls = 0;  // no points, no calls
  forEachResponsibility(g, Eigen::Matrix3Xd(3, 0), 2,
                        [&calls](Eigen::Index, const double*, double) { ++calls; });
  EXPECT_EQ(calls, 0);
}
