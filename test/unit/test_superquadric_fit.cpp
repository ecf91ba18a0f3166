// Superquadric fitting (eq. 3, Ceres LM) against seeded synthetic superquadrics with known
// parameters: full and one-sided noisy views, degenerate inputs, multi-scale refinement.
#include <gtest/gtest.h>

#include <ceres/rotation.h>

#include <cmath>
#include <memory>
#include <random>

#include "novelty_detection/shape/shape_retrieval.h"
#include "novelty_detection/shape/superquadric.h"
#include "novelty_detection/shape/superquadric_cost.h"
#include "novelty_detection/shape/superquadric_fit.h"
#include "superquadric_samples.h"

using namespace novelty_detection;
using samples::makeSq;

namespace {

struct Case {
  const char* name;
  Superquadric truth;
};

std::vector<Case> cases() {
  return {{"box", makeSq({0.30, 0.20, 0.50}, 0.2, 0.2)},
          {"box_sharp", makeSq({0.25, 0.40, 0.15}, 0.1, 0.1)},
          {"cylinder", makeSq({0.15, 0.15, 0.45}, 0.1, 1.0)},
          {"sphere", makeSq({0.30, 0.30, 0.30}, 1.0, 1.0)},
          {"ellipsoid", makeSq({0.45, 0.25, 0.15}, 1.0, 1.0)},
          {"octahedron", makeSq({0.35, 0.30, 0.40}, 1.7, 1.7)}};
}

// Noise of a good indoor laser (sigma 5 mm).
constexpr double kSigma = 0.005;

// Half sizes sorted: the fit may permute the axes (a cylinder's axis must be z, the others
// are free), so sizes are compared as sorted triples.
Eigen::Vector3d sorted(Eigen::Vector3d v) {
  std::sort(v.data(), v.data() + 3);
  return v;
}

}  // namespace

class FitFullView : public ::testing::TestWithParam<int> {};

TEST_P(FitFullView, RecoversSurfaceAndSizes) {
  const SuperquadricFitter fitter{SuperquadricParams()};
  std::mt19937 rng(100 + GetParam());
  for (const Case& c : cases()) {
    Superquadric truth = c.truth;
    samples::randomPose(truth, rng);
    const Points3d pts = samples::noisySamples(truth, 500, kSigma, 10u + GetParam());
    const FitResult r = fitter.fit(pts);
    // The noisy samples lie on the fit within the noise (bound 1.5 sigma + 5 mm), and the
    // truth's noise-free surface lies on it within half the noise (measured: <= 1.5 mm).
    const double surface = samples::surfaceError(truth, r.sq);
    EXPECT_LT(r.mean_radial_distance, 1.5 * kSigma + 0.005) << c.name;
    EXPECT_LT(surface, 0.5 * kSigma) << c.name;
    // Sizes within 10 % (or 1 cm).
    const Eigen::Vector3d st = sorted(truth.a), sf = sorted(r.sq.a);
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(sf[k], st[k], std::max(0.01, 0.1 * st[k])) << c.name << " size " << k;
    }
    EXPECT_LT((r.sq.position - truth.position).norm(), 0.02) << c.name;
    EXPECT_TRUE(std::isfinite(r.residual));
  }
}

INSTANTIATE_TEST_SUITE_P(Seeds, FitFullView, ::testing::Values(0, 1, 2));

class FitPartialView : public ::testing::TestWithParam<int> {};

TEST_P(FitPartialView, OneSidedViewStaysOnTheVisibleSurface) {
  // A sensor 3 m away sees one side only. The hidden depth is not observable, so the test
  // asserts what is: the visible points lie on the fit (mean radial distance bound), the
  // fit neither collapses (every size >= min bound) nor explodes (sizes within 2x the
  // truth's largest), and its surface passes through the truth's visible surface.
  const SuperquadricParams params;
  const SuperquadricFitter fitter{params};
  std::mt19937 rng(200 + GetParam());
  for (const Case& c : cases()) {
    Superquadric truth = c.truth;
    samples::randomPose(truth, rng);
    const Eigen::Vector3d sensor = truth.position + Eigen::Vector3d(3.0, 0.5, 1.0);
    const Points3d pts = samples::noisySamples(truth, 1000, kSigma, 20u + GetParam(), &sensor);
    ASSERT_GT(pts.size(), 200u);
    const FitResult r = fitter.fit(pts);
    EXPECT_LT(r.mean_radial_distance, 1.5 * kSigma + 0.005) << c.name;
    const Points3d clean_visible = samples::noisySamples(truth, 1000, 0.0, 20u, &sensor);
    EXPECT_LT(meanRadialDistance(r.sq, clean_visible), 1.5 * kSigma) << c.name;
    EXPECT_GE(r.sq.a.minCoeff(), params.min_size_m);
    EXPECT_LT(r.sq.a.maxCoeff(), 2.0 * truth.a.maxCoeff()) << c.name;
    EXPECT_LT((r.sq.position - truth.position).norm(), 2.0 * truth.a.maxCoeff()) << c.name;
  }
}

INSTANTIATE_TEST_SUITE_P(Seeds, FitPartialView, ::testing::Values(0, 1, 2));

TEST(SuperquadricFit, MomentGuessesOfAFullSphereAreExact) {
  const Superquadric truth = makeSq({0.4, 0.4, 0.4}, 1.0, 1.0, {0, 0, 0}, {1, 2, 3});
  const SuperquadricFitter fitter{SuperquadricParams()};
  const auto guesses = fitter.initialGuesses(sampleSurfaceRandom(truth, 20000, 4u));
  ASSERT_EQ(guesses.size(), 6u);
  // Moment sizes: a = sqrt(3 lambda) is exact for a sphere's surface.
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(guesses[k].a.maxCoeff(), 0.4, 0.01);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(guesses[k].a.minCoeff(), 0.4, 0.01);
  EXPECT_LT((guesses[0].position - truth.position).norm(), 0.01);
}

TEST(SuperquadricFit, RobustLossToleratesOutliers) {
  SuperquadricParams params;
  params.robust_loss = "cauchy";
  const SuperquadricFitter fitter{params};
  const Superquadric truth = makeSq({0.3, 0.2, 0.4}, 0.3, 0.3, {0.2, 0.5, 0.1}, {0, 1, 0});
  Points3d pts = samples::noisySamples(truth, 500, kSigma, 5u);
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < 25; ++i)
    pts.push_back(truth.position + Eigen::Vector3d(u(rng), u(rng), u(rng)));
  const FitResult r = fitter.fit(pts);
  EXPECT_LT(samples::surfaceError(truth, r.sq), 2.0 * kSigma);
}

TEST(SuperquadricFit, DegenerateInputsGiveFiniteFitsOrClearErrors) {
  const SuperquadricFitter fitter{SuperquadricParams()};
  EXPECT_THROW(fitter.fit({}), std::invalid_argument);
  EXPECT_THROW(fitter.fit({Eigen::Vector3d(0, 0, NAN)}), std::invalid_argument);
  const std::vector<Points3d> degenerate = {
      {Eigen::Vector3d(1, 2, 3)},              // one point
      Points3d(30, Eigen::Vector3d(1, 1, 1)),  // duplicates
      [] {
        Points3d p;
        for (int i = 0; i < 30; ++i) p.emplace_back(0.01 * i, 0, 0);
        return p;
      }(),
      [] {
        Points3d p;
        for (int i = 0; i < 100; ++i) p.emplace_back(0.01 * (i % 10), 0.01 * (i / 10), 0);
        return p;
      }(),
  };
  for (const auto& pts : degenerate) {
    const FitResult r = fitter.fit(pts);
    EXPECT_TRUE(r.sq.a.allFinite() && r.sq.euler.allFinite() && r.sq.position.allFinite());
    EXPECT_TRUE(std::isfinite(r.mean_radial_distance) && std::isfinite(r.residual));
    EXPECT_GE(r.sq.a.minCoeff(), SuperquadricParams().min_size_m);
  }
}

TEST(ShapeRetrieval, MultiScaleFitOfOneBoxIsOnePart) {
  const Superquadric truth = makeSq({0.25, 0.15, 0.4}, 0.2, 0.2, {0.4, 1.1, -0.3}, {2, 1, 0.5});
  const Points3d fine = samples::noisySamples(truth, 3000, kSigma, 8u);
  const Points3d coarse = subsample(fine, 100);
  const ShapeRetrieval retrieval{SuperquadricParams()};
  const std::vector<Superquadric> sqs = retrieval.recover(fine, coarse, 7);
  ASSERT_EQ(sqs.size(), 1u);
  EXPECT_EQ(sqs[0].segment, 7);
  EXPECT_EQ(sqs[0].points, 3000);
  EXPECT_EQ(sqs[0].indices.size(), 3000u);
  EXPECT_LT(samples::surfaceError(truth, sqs[0]), kSigma);
  EXPECT_NEAR(sqs[0].residual, meanSquaredResidual(sqs[0], fine), 1e-12);
  EXPECT_THROW(retrieval.recover({}, coarse, 1), std::invalid_argument);
  SuperquadricParams off;
  off.enabled = false;
  EXPECT_TRUE(ShapeRetrieval(off).recover(fine, coarse, 1).empty());
}

TEST(SuperquadricCost, AnalyticJacobianEqualsAutodiff) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Vector3d q(u(rng), u(rng), u(rng));
    double a[3] = {0.3 + 0.2 * u(rng), 0.3 + 0.2 * u(rng), 0.3 + 0.2 * u(rng)};
    double e[2] = {1.0 + 0.85 * u(rng), 1.0 + 0.85 * u(rng)};
    // Rotation vectors from zero (series branch) to large angles.
    const double scale = trial % 4 == 0 ? 1e-6 : 1.5;
    double w[3] = {scale * u(rng), scale * u(rng), scale * u(rng)};
    double t[3] = {0.2 * u(rng), 0.2 * u(rng), 0.2 * u(rng)};
    const double* params[4] = {a, e, w, t};
    std::unique_ptr<ceres::CostFunction> ad(SuperquadricResidual::Create(q));
    std::unique_ptr<ceres::CostFunction> an(SuperquadricAnalyticResidual::Create(q));
    double r_ad, r_an, j_ad[4][3], j_an[4][3];
    double* jac_ad[4] = {j_ad[0], j_ad[1], j_ad[2], j_ad[3]};
    double* jac_an[4] = {j_an[0], j_an[1], j_an[2], j_an[3]};
    ASSERT_TRUE(ad->Evaluate(params, &r_ad, jac_ad));
    ASSERT_TRUE(an->Evaluate(params, &r_an, jac_an));
    EXPECT_NEAR(r_an, r_ad, 1e-9 * (1.0 + std::abs(r_ad)));
    const int sizes[4] = {3, 2, 3, 3};
    for (int b = 0; b < 4; ++b) {
      for (int i = 0; i < sizes[b]; ++i) {
        EXPECT_NEAR(j_an[b][i], j_ad[b][i], 1e-7 * (1.0 + std::abs(j_ad[b][i])))
            << "block " << b << " index " << i << " trial " << trial;
      }
    }
  }
}

namespace {

/// The first-order surface distance written with Jets (the reference for the analytic one):
/// (1 - exp(-e1 log F / 2)) / (e1/2 |grad_p log F|), the point p = Exp(w)^T (q - t).
struct SurfaceDistanceAutodiff {
  explicit SurfaceDistanceAutodiff(const Eigen::Vector3d& q) : q_(q) {}
  template <class T>
  bool operator()(const T* const a, const T* const e, const T* const w, const T* const t,
                  T* residual) const {
    using std::exp;
    using std::log;
    using std::sqrt;
    const T d[3] = {T(q_.x()) - t[0], T(q_.y()) - t[1], T(q_.z()) - t[2]};
    const T minus_w[3] = {-w[0], -w[1], -w[2]};
    T p[3];
    ceres::AngleAxisRotatePoint(minus_w, d, p);
    const T tiny(kSqTinySquared);
    const T lx = log(p[0] * p[0] / (a[0] * a[0]) + tiny) / e[1];
    const T ly = log(p[1] * p[1] / (a[1] * a[1]) + tiny) / e[1];
    const T lz = log(p[2] * p[2] / (a[2] * a[2]) + tiny) / e[0];
    const T lxy = logSumExp(lx, ly);
    const T la = (e[1] / e[0]) * lxy;
    const T l = logSumExp(la, lz);
    const T wa = exp(la - l), wb = exp(lz - l), wx = exp(lx - lxy), wy = exp(ly - lxy);
    const T vx = wa * wx * p[0] / (p[0] * p[0] + tiny * a[0] * a[0]);
    const T vy = wa * wy * p[1] / (p[1] * p[1] + tiny * a[1] * a[1]);
    const T vz = wb * p[2] / (p[2] * p[2] + tiny * a[2] * a[2]);
    residual[0] = (T(1.0) - exp(T(-0.5) * e[0] * l)) / sqrt(vx * vx + vy * vy + vz * vz + T(1e-24));
    return true;
  }
  Eigen::Vector3d q_;
};

}  // namespace

// The analytic first-order surface distance against the same formula differentiated by
// Jets, from round to box-like and pinched shapes, points inside and outside; its value is
// the library's surfaceDistance() with the sign of the side.
TEST(SuperquadricCost, SurfaceDistanceJacobianEqualsAutodiff) {
  std::mt19937 rng(12);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 300; ++trial) {
    const Eigen::Vector3d q(0.6 * u(rng), 0.6 * u(rng), 0.6 * u(rng));
    double a[3] = {0.3 + 0.2 * u(rng), 0.3 + 0.2 * u(rng), 0.3 + 0.2 * u(rng)};
    double e[2] = {1.0 + 0.9 * u(rng), 1.0 + 0.9 * u(rng)};
    const double scale = trial % 4 == 0 ? 1e-6 : 1.5;
    double w[3] = {scale * u(rng), scale * u(rng), scale * u(rng)};
    double t[3] = {0.2 * u(rng), 0.2 * u(rng), 0.2 * u(rng)};
    const double* params[4] = {a, e, w, t};
    std::unique_ptr<ceres::CostFunction> ad(
        new ceres::AutoDiffCostFunction<SurfaceDistanceAutodiff, 1, 3, 2, 3, 3>(
            new SurfaceDistanceAutodiff(q)));
    const SuperquadricSurfaceResidual an({q}, 2.0);
    double r_ad, r_an, j_ad[4][3], j_an[4][3];
    double* jac_ad[4] = {j_ad[0], j_ad[1], j_ad[2], j_ad[3]};
    double* jac_an[4] = {j_an[0], j_an[1], j_an[2], j_an[3]};
    ASSERT_TRUE(ad->Evaluate(params, &r_ad, jac_ad));
    ASSERT_TRUE(an.Evaluate(params, &r_an, jac_an));
    EXPECT_NEAR(r_an, 2.0 * r_ad, 1e-9 * (1.0 + std::abs(r_ad)));
    const int sizes[4] = {3, 2, 3, 3};
    for (int b = 0; b < 4; ++b) {
      for (int i = 0; i < sizes[b]; ++i) {
        EXPECT_NEAR(j_an[b][i], 2.0 * j_ad[b][i], 1e-6 * (1.0 + std::abs(j_ad[b][i])))
            << "block " << b << " index " << i << " trial " << trial;
      }
    }
    if (scale < 1.0) {
      Superquadric sq;
      sq.a = Eigen::Vector3d(a[0], a[1], a[2]);
      sq.e1 = e[0];
      sq.e2 = e[1];
      sq.position = Eigen::Vector3d(t[0], t[1], t[2]);
      const double side = insideOutside(sq, q) < 1.0 ? -1.0 : 1.0;
      EXPECT_NEAR(r_an / 2.0, side * surfaceDistance(sq, q), 1e-6 * (1.0 + std::abs(r_an)))
          << "trial " << trial;
    }
  }
}

TEST(SuperquadricFit, AutodiffAndAnalyticFitsAgree) {
  const Superquadric truth = makeSq({0.3, 0.2, 0.4}, 0.4, 0.8, {0.5, 0.7, 0.2}, {1, 0, 2});
  const Points3d pts = samples::noisySamples(truth, 400, kSigma, 12u);
  SuperquadricParams params;
  const FitResult an = SuperquadricFitter(params).fit(pts);
  params.autodiff = true;
  const FitResult ad = SuperquadricFitter(params).fit(pts);
  EXPECT_NEAR(an.mean_radial_distance, ad.mean_radial_distance, 1e-4);
  EXPECT_LT(samples::surfaceError(ad.sq, an.sq), 1e-3);
}
