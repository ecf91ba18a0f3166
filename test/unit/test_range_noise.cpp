// The sensor noise model fitted to a sweep's own planar patches (preprocess/range_noise.h):
// seeded patches at known ranges with known range noise recover the model and its scale.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>

#include "novelty_detection/preprocess/multiscale_tree.h"
#include "novelty_detection/preprocess/range_noise.h"

namespace nd = novelty_detection;

namespace {

/// Square patches (side 0.6 m, 3000 points each) facing a sensor at `origin`, at ranges
/// 1, 1.5, ..., 6 m in different directions, each point displaced along its ray by noise of
/// standard deviation sigma(range).
nd::Cloud patches(const Eigen::Vector3f& origin, const std::function<double(double)>& sigma,
                  unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-0.3f, 0.3f);
  std::normal_distribution<double> g(0.0, 1.0);
  nd::Cloud c;
  int k = 0;
  for (double r = 1.0; r <= 6.0 + 1e-9; r += 0.5, ++k) {
    const double az = 0.55 * k;  // a direction per patch
    const Eigen::Vector3f n(std::cos(az), std::sin(az), 0.1f * (k % 3 - 1));
    const Eigen::Vector3f dir = n.normalized();
    const Eigen::Vector3f a = dir.cross(Eigen::Vector3f::UnitZ()).normalized();
    const Eigen::Vector3f b = dir.cross(a);
    for (int i = 0; i < 3000; ++i) {
      const Eigen::Vector3f p = origin + static_cast<float>(r) * dir + u(rng) * a + u(rng) * b;
      const Eigen::Vector3f ray = (p - origin).normalized();
      const Eigen::Vector3f q = p + static_cast<float>(sigma((p - origin).norm()) * g(rng)) * ray;
      c.push_back(nd::PointT(q.x(), q.y(), q.z()));
    }
  }
  return c;
}

nd::RangeNoise fit(const nd::Cloud& cloud, const Eigen::Vector3f* origin) {
  nd::MultiScaleTree tree;
  tree.build(cloud);
  return nd::estimateRangeNoise(tree, origin);
}

/// The model found: its exponent and name, and sigma at `range_m` within `tol_m`.
void expectModel(const nd::RangeNoise& n, double exponent, const char* name, double range_m,
                 double sigma_m, double tol_m) {
  ASSERT_TRUE(n.estimated);
  EXPECT_EQ(n.exponent, exponent);
  EXPECT_EQ(n.modelName(), name);
  EXPECT_NEAR(n.sigmaAt(range_m), sigma_m, tol_m);
}

}  // namespace

TEST(RangeNoise, ConstantNoiseIsConstant) {
  const Eigen::Vector3f o(2.f, -1.f, 0.5f);
  const nd::RangeNoise n = fit(patches(
                                   o, [](double) { return 0.01; }, 1),
                               &o);
  expectModel(n, 0.0, "constant", 3.0, 0.01, 0.0015);
}

TEST(RangeNoise, LinearNoiseIsLinear) {
  const Eigen::Vector3f o(0.f, 0.f, 0.f);
  const nd::RangeNoise n = fit(patches(
                                   o, [](double r) { return 0.002 * r; }, 2),
                               &o);
  expectModel(n, 1.0, "linear in range", 1.0, 0.002, 0.0003);
  EXPECT_NEAR(n.sigmaAt(5.0), 0.010, 0.0015);
}

TEST(RangeNoise, DepthCameraNoiseIsQuadratic) {
  const Eigen::Vector3f o(1.f, 1.f, 1.f);
  const nd::RangeNoise n = fit(patches(
                                   o, [](double r) { return 0.0015 * r * r; }, 3),
                               &o);
  expectModel(n, 2.0, "quadratic in range", 2.0, 0.006, 0.0009);
}

TEST(RangeNoise, WithoutAnOriginOnlyTheConstantIsFitted) {
  const Eigen::Vector3f o(0.f, 0.f, 0.f);
  const nd::RangeNoise n = fit(patches(
                                   o, [](double r) { return 0.002 * r; }, 4),
                               nullptr);
  ASSERT_TRUE(n.estimated);
  EXPECT_EQ(n.exponent, 0.0);
  // A typical patch's noise: above the nearest (2 mm), well below the farthest (12 mm); the
  // nearer, thinner patches hold more plate-like nodes and so cast more of the votes.
  EXPECT_GT(n.sigmaAt(0.0), 0.0025);
  EXPECT_LT(n.sigmaAt(0.0), 0.009);
}

TEST(RangeNoise, TooFewPatchesGiveNoEstimate) {
  nd::Cloud c;
  for (int i = 0; i < 10; ++i) c.push_back(nd::PointT(0.1f * i, 0.f, 0.f));
  const Eigen::Vector3f o(0.f, 0.f, -1.f);
  const nd::RangeNoise n = fit(c, &o);
  EXPECT_FALSE(n.estimated);
  EXPECT_EQ(n.sigmaAt(4.0), 0.0);
  nd::MultiScaleTree empty;
  EXPECT_FALSE(nd::estimateRangeNoise(empty, &o).estimated);
}
