// Fine alignment (alignment.h) against known localisation errors on simulated scenes with
// exact ground truth: the error transform E is applied to the current sweep as the
// localisation would, and the estimated correction T must undo it (T * E ~ identity).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "novelty_detection/alignment/alignment.h"
#include "novelty_detection/pipeline.h"
#include "novelty_detection/sim/scene.h"

using namespace novelty_detection;

namespace {

constexpr double kDeg = M_PI / 180.0;

/// Range noise of a Hokuyo UTM-30LX class scanner: sigma = 1 cm. (The simulator's default,
/// 0.001 m^2, is sigma = 3.2 cm; see SimulatorDefaultNoise.)
constexpr double kLaserNoiseVariance = 1e-4;

sim::ScenePair scene(std::uint64_t seed, sim::Layout layout = sim::Layout::kCorridor,
                     std::vector<sim::NoveltyKind> kinds = {sim::NoveltyKind::kBox},
                     double noise_variance_m2 = kLaserNoiseVariance) {
  sim::SceneConfig c;
  c.seed = seed;
  c.layout = layout;
  c.novelty_kinds = std::move(kinds);
  c.laser.noise_variance_m2 = noise_variance_m2;
  return sim::generateScenePair(c);
}

Eigen::Vector3d sensorOrigin(const Cloud& c) { return c.sensor_origin_.head<3>().cast<double>(); }

/// A localisation error: rotation by angle_deg about `axis` through the sensor origin, then a
/// translation of `shift`.
Eigen::Isometry3d poseError(const Eigen::Vector3d& origin, const Eigen::Vector3d& shift,
                            const Eigen::Vector3d& axis, double angle_deg) {
  Eigen::Isometry3d E = Eigen::Isometry3d::Identity();
  E.linear() = Eigen::AngleAxisd(angle_deg * kDeg, axis.normalized()).toRotationMatrix();
  E.translation() = origin - E.linear() * origin + shift;
  return E;
}

struct Residual {
  double translation_m, rotation_deg;
};

/// What is left of the error after the correction, at the sensor origin.
Residual residual(const Eigen::Isometry3d& T, const Eigen::Isometry3d& E,
                  const Eigen::Vector3d& origin) {
  const Eigen::Isometry3d left = T * E;
  return {(left * origin - origin).norm(), Eigen::AngleAxisd(left.rotation()).angle() / kDeg};
}

AlignmentResult align(const sim::ScenePair& s, const Eigen::Isometry3d& E,
                      const AlignmentParams& p = AlignmentParams()) {
  AlignmentReference ref;
  ref.build(s.reference, p);
  return FineAligner(p).estimate(ref, transformCloud(s.current, E));
}

}  // namespace

struct ErrorCase {
  std::uint64_t seed;
  sim::Layout layout;
  Eigen::Vector3d shift;
  Eigen::Vector3d axis;
};

class LocalisationError : public ::testing::TestWithParam<ErrorCase> {};

// A 2 cm / 0.5 deg localisation error is corrected to within 5 mm / 0.1 deg.
TEST_P(LocalisationError, CorrectedWithin5mmAndATenthOfADegree) {
  const ErrorCase& c = GetParam();
  const sim::ScenePair s = scene(c.seed, c.layout);
  const Eigen::Vector3d o = sensorOrigin(s.current);
  const Eigen::Isometry3d E = poseError(o, 0.02 * c.shift.normalized(), c.axis, 0.5);
  const AlignmentResult a = align(s, E);
  ASSERT_TRUE(a.applied) << a.status;
  const Residual r = residual(a.correction, E, o);
  EXPECT_LT(r.translation_m, 0.005);
  EXPECT_LT(r.rotation_deg, 0.1);
  EXPECT_NEAR(a.translation_m, 0.02, 0.005);
  EXPECT_NEAR(a.rotation_deg, 0.5, 0.1);
  EXPECT_GT(a.inlier_fraction, 0.5);
}

INSTANTIATE_TEST_SUITE_P(
    Simulated, LocalisationError,
    ::testing::Values(ErrorCase{3, sim::Layout::kCorridor, {1, 0, 0}, {0, 0, 1}},
                      ErrorCase{5, sim::Layout::kCorridor, {0, 1, 0}, {1, 0, 0}},
                      ErrorCase{8, sim::Layout::kOffice, {1, 1, 0}, {0, 1, 0}},
                      ErrorCase{11, sim::Layout::kOffice, {0, 0, 1}, {0, 0, 1}},
                      ErrorCase{13, sim::Layout::kOffice, {1, -1, 1}, {1, 1, 1}},
                      ErrorCase{17, sim::Layout::kCorridor, {-1, 1, -1}, {1, -1, 2}}));

// At the simulator's default range noise (sigma = 3.2 cm) the correction is noise-limited:
// measured 1-5 mm / 0.01-0.12 deg per scene, mean ~2.5 mm / 0.06 deg. Asserted on the mean
// with a per-scene ceiling, for every correction (min_cost_reduction 0). The error costs less
// against that noise: the correction lowers the cost by 3.8-13.8 % (at 1 cm, tens of per
// cent), so that seed 1's (3.8 %) stays below the default bar and is not applied.
TEST(FineAlignment, SimulatorDefaultNoise) {
  double sum_t = 0.0, sum_r = 0.0;
  const int n = 6;
  for (int seed = 1; seed <= n; ++seed) {
    const sim::ScenePair s =
        scene(seed, seed % 2 ? sim::Layout::kCorridor : sim::Layout::kOffice,
              {sim::NoveltyKind::kPerson}, sim::LaserConfig().noise_variance_m2);
    const Eigen::Vector3d o = sensorOrigin(s.current);
    const Eigen::Isometry3d E =
        poseError(o, 0.02 * Eigen::Vector3d(1, -seed, 1).normalized(), {double(seed), 1, 2}, 0.5);
    AlignmentParams every;
    every.min_cost_reduction = 0.0;
    const AlignmentResult a = align(s, E, every);
    ASSERT_TRUE(a.applied) << "seed " << seed << ": " << a.status;
    EXPECT_GT(a.cost_reduction, 0.035) << "seed " << seed;
    EXPECT_EQ(align(s, E).applied, a.cost_reduction >= AlignmentParams().min_cost_reduction)
        << "seed " << seed;
    const Residual r = residual(a.correction, E, o);
    EXPECT_LT(r.translation_m, 0.01) << "seed " << seed;
    EXPECT_LT(r.rotation_deg, 0.2) << "seed " << seed;
    sum_t += r.translation_m;
    sum_r += r.rotation_deg;
  }
  EXPECT_LT(sum_t / n, 0.005);
  EXPECT_LT(sum_r / n, 0.1);
}

// Changed objects (a person and a box) are outliers: they do not pull the pose.
TEST(FineAlignment, InsertedObjectsDoNotPullThePose) {
  const sim::ScenePair s =
      scene(29, sim::Layout::kOffice, {sim::NoveltyKind::kPerson, sim::NoveltyKind::kBox});
  const Eigen::Vector3d o = sensorOrigin(s.current);
  const Eigen::Isometry3d E = poseError(o, {0.0, -0.02, 0.0}, {0, 0, 1}, -0.5);
  const AlignmentResult a = align(s, E);
  ASSERT_TRUE(a.applied) << a.status;
  const Residual r = residual(a.correction, E, o);
  EXPECT_LT(r.translation_m, 0.005);
  EXPECT_LT(r.rotation_deg, 0.1);
}

// Same pose: the correction found is about zero, gains almost nothing and is not applied
// (min_cost_reduction); applied when every correction is.
TEST(FineAlignment, SamePoseGivesNoCorrection) {
  for (std::uint64_t seed : {3u, 8u}) {
    const sim::ScenePair s =
        scene(seed, seed == 3u ? sim::Layout::kCorridor : sim::Layout::kOffice);
    const AlignmentResult a = align(s, Eigen::Isometry3d::Identity());
    EXPECT_TRUE(a.attempted);
    EXPECT_FALSE(a.applied) << "seed " << seed;
    EXPECT_NE(a.status.find("min_cost_reduction"), std::string::npos) << a.status;
    EXPECT_LT(a.cost_reduction, 0.01) << "seed " << seed;
    EXPECT_LT(a.translation_m, 0.002) << "seed " << seed;
    EXPECT_LT(a.rotation_deg, 0.05) << "seed " << seed;
    AlignmentParams every;
    every.min_cost_reduction = 0.0;
    const AlignmentResult b = align(s, Eigen::Isometry3d::Identity(), every);
    ASSERT_TRUE(b.applied) << b.status;
    EXPECT_LT(b.translation_m, 0.002) << "seed " << seed;
    EXPECT_LT(b.rotation_deg, 0.05) << "seed " << seed;
  }
}

// Beyond the bound: rejected, reported, correction not applied.
TEST(FineAlignment, ErrorBeyondTheBoundIsRejected) {
  const sim::ScenePair s = scene(5, sim::Layout::kOffice);
  const Eigen::Vector3d o = sensorOrigin(s.current);
  AlignmentParams p;
  p.max_translation_m = 0.05;
  p.max_rotation_deg = 1.0;
  // 12 cm with a 5 cm bound: found, and refused.
  const AlignmentResult far = align(s, poseError(o, {0.0, 0.12, 0.0}, {0, 0, 1}, 0.0), p);
  EXPECT_TRUE(far.attempted);
  EXPECT_FALSE(far.applied) << far.status << " " << far.translation_m << " m";
  EXPECT_NE(far.status.find("max_translation_m"), std::string::npos) << far.status;
  // 3 deg with a 1 deg bound.
  const AlignmentResult turned = align(s, poseError(o, {0.0, 0.0, 0.0}, {0, 0, 1}, 3.0), p);
  EXPECT_FALSE(turned.applied);
  EXPECT_NE(turned.status.find("rejected"), std::string::npos) << turned.status;
  // The same errors within the default bound are corrected.
  const Eigen::Isometry3d E = poseError(o, {0.1, 0.0, 0.0}, {0, 0, 1}, 0.0);
  const AlignmentResult ok = align(s, E);
  ASSERT_TRUE(ok.applied) << ok.status;
  EXPECT_LT(residual(ok.correction, E, o).translation_m, 0.005);
}

namespace {

/// Samples of an axis-aligned rectangle patch with Gaussian noise along its normal.
void addPlane(Cloud& cloud, std::mt19937& rng, const Eigen::Vector3d& corner,
              const Eigen::Vector3d& u, const Eigen::Vector3d& v, int nu, int nv, double noise_m) {
  std::uniform_real_distribution<double> jitter(0.0, 1.0);
  std::normal_distribution<double> g(0.0, noise_m);
  const Eigen::Vector3d n = u.cross(v).normalized();
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const Eigen::Vector3d p =
          corner + u * ((i + jitter(rng)) / nu) + v * ((j + jitter(rng)) / nv) + n * g(rng);
      cloud.push_back(PointT(p.x(), p.y(), p.z()));
    }
}

/// An endless corridor along x: floor, ceiling, two walls. Nothing constrains x.
Cloud corridor(std::uint32_t seed) {
  std::mt19937 rng(seed);
  Cloud c;
  const double len = 16.0, w = 2.0, h = 2.5, noise = 0.01;
  addPlane(c, rng, {-len / 2, -w / 2, 0}, {len, 0, 0}, {0, w, 0}, 160, 20, noise);
  addPlane(c, rng, {-len / 2, -w / 2, h}, {len, 0, 0}, {0, w, 0}, 160, 20, noise);
  addPlane(c, rng, {-len / 2, -w / 2, 0}, {len, 0, 0}, {0, 0, h}, 160, 25, noise);
  addPlane(c, rng, {-len / 2, w / 2, 0}, {len, 0, 0}, {0, 0, h}, 160, 25, noise);
  c.sensor_origin_ = Eigen::Vector4f(0.f, 0.f, 0.6f, 0.f);
  return c;
}

}  // namespace

// A corridor constrains nothing along its axis: that direction is left as given (no wild
// correction) and reported; the constrained ones are corrected.
TEST(FineAlignment, CorridorAxisIsLeftUnchanged) {
  const Cloud reference = corridor(1);
  const Eigen::Vector3d o(0, 0, 0.6);
  const Eigen::Isometry3d E = poseError(o, {0.05, 0.02, -0.01}, {0, 0, 1}, 0.3);
  const Cloud current = transformCloud(corridor(2), E);
  AlignmentReference ref;
  const AlignmentParams p;
  ref.build(reference, p);
  const AlignmentResult a = FineAligner(p).estimate(ref, current);
  ASSERT_TRUE(a.applied) << a.status;
  EXPECT_GE(a.degenerate_directions, 1);
  EXPECT_NE(a.status.find("unconstrained"), std::string::npos) << a.status;
  // Along x the sweep moves by less than 5 mm (no drift on noise); y, z and yaw are undone.
  const Eigen::Isometry3d left = a.correction * E;
  const Eigen::Vector3d t = left * o - o;
  EXPECT_NEAR(t.x(), 0.05, 0.005);
  EXPECT_LT(std::abs(t.y()), 0.003);
  EXPECT_LT(std::abs(t.z()), 0.003);
  EXPECT_LT(Eigen::AngleAxisd(left.rotation()).angle() / kDeg, 0.05);
}

// Degenerate inputs: never a wild correction, never a throw.
TEST(FineAlignment, DegenerateInputsAreRejectedOrPartial) {
  const AlignmentParams p;
  AlignmentReference ref;
  ref.build(corridor(1), p);
  const FineAligner aligner(p);
  const AlignmentResult empty = aligner.estimate(ref, Cloud());
  EXPECT_FALSE(empty.applied);
  EXPECT_NE(empty.status.find("too few points"), std::string::npos) << empty.status;
  Cloud few;
  for (int i = 0; i < 10; ++i) few.push_back(PointT(0.1f * i, 0.f, 0.f));
  EXPECT_FALSE(aligner.estimate(ref, few).applied);
  // An empty reference has no planes.
  AlignmentReference none;
  none.build(Cloud(), p);
  EXPECT_TRUE(none.empty());
  EXPECT_FALSE(aligner.estimate(none, corridor(2)).applied);
  // A floor alone constrains z, roll and pitch only: x, y and yaw stay as given.
  std::mt19937 rng(4);
  Cloud floor_ref, floor_cur;
  addPlane(floor_ref, rng, {-4, -4, 0}, {8, 0, 0}, {0, 8, 0}, 80, 80, 0.01);
  addPlane(floor_cur, rng, {-4, -4, 0}, {8, 0, 0}, {0, 8, 0}, 80, 80, 0.01);
  AlignmentReference floor_planes;
  floor_planes.build(floor_ref, p);
  const Eigen::Isometry3d E =
      poseError(Eigen::Vector3d::Zero(), {0.03, 0.03, 0.02}, {0, 0, 1}, 1.0);
  const AlignmentResult f = aligner.estimate(floor_planes, transformCloud(floor_cur, E));
  ASSERT_TRUE(f.applied) << f.status;
  EXPECT_EQ(f.degenerate_directions, 3);
  EXPECT_LT(std::abs(f.correction.translation().z() + 0.02), 0.003);
  EXPECT_LT(f.correction.translation().head<2>().norm(), 0.005);
  EXPECT_LT(Eigen::AngleAxisd(f.correction.rotation()).angle() / kDeg, 0.1);
}

// Far coordinates: no overflow, no crash, a finite (rejected or applied) result.
TEST(FineAlignment, HugeCoordinatesGiveAFiniteResult) {
  const AlignmentParams p;
  AlignmentReference ref;
  ref.build(corridor(1), p);
  Cloud far = corridor(2);
  far.push_back(PointT(1e6f, -1e6f, 3e38f));
  far.push_back(PointT(-3e38f, 3e38f, -1e6f));
  const AlignmentResult a = FineAligner(p).estimate(ref, far);
  EXPECT_TRUE(a.correction.matrix().allFinite());
  EXPECT_TRUE(std::isfinite(a.translation_m) && std::isfinite(a.rotation_deg));
  Eigen::Isometry3d shift = Eigen::Isometry3d::Identity();
  shift.translation() = Eigen::Vector3d(1e6, -1e6, 0);
  AlignmentReference moved;
  moved.build(transformCloud(corridor(1), shift), p);
  const AlignmentResult b = FineAligner(p).estimate(moved, transformCloud(corridor(2), shift));
  EXPECT_TRUE(b.correction.matrix().allFinite()) << b.status;
}

TEST(FineAlignment, TransformCloudKeepsOrderNaNsAndMovesTheOrigin) {
  Cloud c;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  c.push_back(PointT(1.f, 0.f, 0.f));
  c.push_back(PointT(nan, nan, nan));
  c.push_back(PointT(0.f, 2.f, 0.f));
  c.sensor_origin_ = Eigen::Vector4f(1.f, 1.f, 1.f, 0.f);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.5, 0, 0);
  const Cloud t = transformCloud(c, T);
  ASSERT_EQ(t.size(), 3u);
  EXPECT_NEAR(t[0].x, 0.5f, 1e-6f);
  EXPECT_NEAR(t[0].y, 1.f, 1e-6f);
  EXPECT_TRUE(std::isnan(t[1].x));
  EXPECT_NEAR(t[2].x, -1.5f, 1e-6f);
  EXPECT_NEAR(t.sensor_origin_.x(), -0.5f, 1e-6f);
  EXPECT_NEAR(t.sensor_origin_.y(), 1.f, 1e-6f);
  EXPECT_NEAR(t.sensor_origin_.z(), 1.f, 1e-6f);
}
