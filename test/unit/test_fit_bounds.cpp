// Bounded superquadric fits (shape/fit_bounds.h): the support function, the floor test, the
// hidden side by symmetry, and one-sided simulated laser views of standing objects whose
// true superquadrics are known.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "novelty_detection/params.h"
#include "novelty_detection/preprocess/range_noise.h"
#include "novelty_detection/shape/fit_bounds.h"
#include "novelty_detection/shape/shape_retrieval.h"
#include "novelty_detection/shape/superquadric.h"
#include "novelty_detection/shape/superquadric_fit.h"
#include "novelty_detection/sim/scene.h"
#include "novelty_detection/visibility/visibility.h"
#include "sim_objects.h"
#include "superquadric_samples.h"

using namespace novelty_detection;
using samples::makeSq;
using samples::semiAxisError;

TEST(FitBounds, ExtentAlongIsTheSurfacesFarthestReach) {
  const Superquadric shapes[] = {makeSq({0.4, 0.4, 0.4}, 1.0, 1.0, {0, 0, 0}, {1, 2, 3}),
                                 makeSq({0.3, 0.2, 0.5}, 0.1, 0.1, {0.3, 0.4, -0.2}, {0, 0, 0}),
                                 makeSq({0.2, 0.2, 0.6}, 0.1, 1.0, {0.0, 1.2, 0.5}, {-1, 0, 0.5}),
                                 makeSq({0.25, 0.35, 0.3}, 0.6, 1.4, {1.0, 0.5, 2.0}, {0, 0, 0})};
  const Eigen::Vector3d directions[] = {Eigen::Vector3d::UnitZ(), Eigen::Vector3d(1, 1, 0),
                                        Eigen::Vector3d(0.3, -0.5, 0.8)};
  for (const auto& sq : shapes) {
    const Points3d surface = sampleSurface(sq, 20000);
    for (Eigen::Vector3d u : directions) {
      u.normalize();
      double reach = 0.0;
      for (const auto& p : surface) reach = std::max(reach, u.dot(p - sq.position));
      // The sampled surface reaches a little less far than the exact support.
      EXPECT_NEAR(extentAlong(sq, u), reach, 0.01 * reach + 0.002)
          << "e " << sq.e1 << " " << sq.e2 << " u " << u.transpose();
      EXPECT_GE(extentAlong(sq, u), reach - 1e-9);
      EXPECT_NEAR(extentAlong(sq, -u), extentAlong(sq, u), 1e-12);
    }
  }
}

TEST(FitBounds, AnObjectStandsOnTheFloorWhenItsPointsComeDownToIt) {
  FitBounds b;
  b.has_floor = true;
  b.up = Eigen::Vector3d::UnitZ();
  b.floor_offset = -0.1;  // floor at z = 0.1
  b.floor_band_m = 0.02;
  b.params.support_fraction = 0.5;
  // Points from 0.3 to 1.3 m above the floor: 0.3 <= 0.02 + 0.5 * 1.0.
  EXPECT_TRUE(b.standsOnFloor({{0, 0, 0.4}, {0, 0, 1.4}}));
  // From 0.5 to 0.9: 0.5 > 0.02 + 0.5 * 0.4 (a box on a table).
  EXPECT_FALSE(b.standsOnFloor({{0, 0, 0.6}, {0, 0, 1.0}}));
  b.has_floor = false;
  EXPECT_FALSE(b.standsOnFloor({{0, 0, 0.1}, {0, 0, 1.0}}));
}

// The front half of a standing cylinder seen from one side: reflected about the vertical
// axis through the middle of its silhouette, the points land on the hidden half.
TEST(FitBounds, TheHiddenHalfOfACylinderIsItsVisibleHalfReflected) {
  const double r = 0.3;
  const Eigen::Vector3d axis(2.0, 1.0, 0.0);
  const Eigen::Vector3d origin(-3.0, 0.0, 0.6);
  const double toward = std::atan2(origin.y() - axis.y(), origin.x() - axis.x());
  Cloud cloud;
  Points3d front;
  for (int i = 0; i < 60; ++i) {
    for (int k = 0; k < 20; ++k) {
      const double phi = toward + M_PI * (i / 59.0 - 0.5);  // the half facing the sensor
      const Eigen::Vector3d p =
          axis + Eigen::Vector3d(r * std::cos(phi), r * std::sin(phi), 0.05 + 0.04 * k);
      front.push_back(p);
      cloud.push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
    }
  }
  RangeImage view;
  view.build(cloud, {}, origin.cast<float>(), RangeImage::Config());
  FitBounds b;
  b.has_floor = true;
  b.floor_band_m = 0.02;
  b.view = &view;
  b.margin_m = 0.02;
  b.params.mirror_max_free = 0.1;
  const Points3d back = mirroredHiddenSide(front, b);
  ASSERT_EQ(back.size(), front.size());
  const Eigen::Vector3d ahead =
      Eigen::Vector3d(axis.x() - origin.x(), axis.y() - origin.y(), 0).normalized();
  // The silhouette's ends are taken from a band of points just inside them: the centre comes
  // out about a tenth of the radius towards the sensor.
  double radius_error = 0.0, hidden = 0.0;
  for (const auto& m : back) {
    radius_error += std::abs(std::hypot(m.x() - axis.x(), m.y() - axis.y()) - r);
    hidden += (m - axis).dot(ahead) > 0.0 ? 1.0 : 0.0;
  }
  EXPECT_LT(radius_error / back.size(), 0.15 * r);  // measured 0.12 r
  EXPECT_GT(hidden / back.size(), 0.8);             // measured 0.83
  // Not standing: no reflection.
  b.has_floor = false;
  EXPECT_TRUE(mirroredHiddenSide(front, b).empty());
}

namespace {

struct BoundedCase {
  double unbounded_error = 0.0, bounded_error = 0.0;
  /// Semi-axis error and mean first-order distance of the points to the bounded fit, with
  /// and without the surface-distance residuals (surface_weight 0: eq. 3 alone).
  double eq3_error = 0.0, surface_distance = 0.0, eq3_surface_distance = 0.0;
  int violations = 0, outside = 0;
  double thinnest = 0.0;  ///< the bounded fit's smallest semi-axis [m]
  bool fitted = false;
};

/// One standing object of `kind` in a simulated scene (seed), fitted as the detector does:
/// bounds from the whole sweep, its labels (the true ones here), its view and the floor.
BoundedCase fitStanding(sim::NoveltyKind kind, std::uint64_t seed,
                        double noise_variance_m2 = sim::SceneConfig().laser.noise_variance_m2) {
  sim::SceneConfig cfg;
  cfg.seed = seed;
  cfg.novelty_kinds = {kind};
  cfg.laser.noise_variance_m2 = noise_variance_m2;
  const sim::ScenePair scene = sim::generateScenePair(cfg);
  BoundedCase c;
  if (scene.objects.empty()) return c;
  const auto& object = scene.objects.front();
  const Points3d fine = sim_objects::objectPoints(scene, object.id);
  if (fine.size() < 50) return c;
  const Points3d coarse = sim_objects::coarsePoints(fine);
  const SuperquadricParams params;
  const auto bounded = sim_objects::boundsOf(scene, cfg, object.id, fine, params);
  const FitBoundsSource& source = bounded->source;
  const FitBounds& bounds = bounded->bounds;
  const ShapeRetrieval retrieval(params);
  const auto loose = retrieval.recover(fine, coarse, object.id);
  const auto tight = retrieval.recover(fine, coarse, object.id, &bounds);
  if (loose.size() != 1 || tight.size() != 1) return c;
  const Superquadric& truth = object.parts.front().sq;
  c.fitted = true;
  c.unbounded_error = semiAxisError(loose[0], truth);
  c.bounded_error = semiAxisError(tight[0], truth);
  c.thinnest = tight[0].a.minCoeff();
  c.violations = outsideViolations(tight[0], bounds, source.margin_m);
  SuperquadricParams eq3_params = params;
  eq3_params.surface_weight = 0.0;
  const FitBounds eq3_bounds = fitBoundsFor(fine, object.id, source, eq3_params);
  const auto eq3 = ShapeRetrieval(eq3_params).recover(fine, coarse, object.id, &eq3_bounds);
  if (eq3.size() != 1) return BoundedCase();
  c.eq3_error = semiAxisError(eq3[0], truth);
  c.surface_distance = meanSurfaceDistance(tight[0], fine);
  c.eq3_surface_distance = meanSurfaceDistance(eq3[0], fine);
  c.outside = static_cast<int>(bounds.outside.size());
  return c;
}

}  // namespace

namespace {
/// The bounded fits' mean semi-axis error stays below this [m].
double toleranceFor(sim::NoveltyKind kind) {
  return kind == sim::NoveltyKind::kSuperellipsoid ? 0.045 : 0.03;
}
}  // namespace

class BoundedKind : public ::testing::TestWithParam<sim::NoveltyKind> {};

// One-sided views at the paper's noise (sigma ~ 3.2 cm), seeds 1-10: the bounded fits'
// semi-axes come closer to the truth than the points alone allow, and no outside point
// lies inside a bounded fit by more than the margin.
TEST_P(BoundedKind, OneSidedViewsAreSizedByWhatTheSweepSaw) {
  double loose = 0.0, tight = 0.0, eq3 = 0.0, surface = 0.0, eq3_surface = 0.0;
  int n = 0, violations = 0, outside = 0;
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    const BoundedCase c = fitStanding(GetParam(), seed);
    if (!c.fitted) continue;
    ++n;
    loose += c.unbounded_error;
    tight += c.bounded_error;
    eq3 += c.eq3_error;
    surface += c.surface_distance;
    eq3_surface += c.eq3_surface_distance;
    violations += c.violations;
    outside += c.outside;
  }
  ASSERT_GE(n, 3) << sim::toString(GetParam());
  loose /= n;
  tight /= n;
  eq3 /= n;
  surface /= n;
  eq3_surface /= n;
  std::printf(
      "%s: semi-axis error unbounded %.1f, eq. 3 alone %.1f, with distances %.1f mm; "
      "mean surface distance %.1f -> %.1f mm\n",
      sim::toString(GetParam()).c_str(), 1000 * loose, 1000 * eq3, 1000 * tight, 1000 * eq3_surface,
      1000 * surface);
  RecordProperty("unbounded_semi_axis_mm", static_cast<int>(1000 * loose));
  RecordProperty("bounded_semi_axis_mm", static_cast<int>(1000 * tight));
  EXPECT_GT(outside, 0);
  EXPECT_EQ(violations, 0) << sim::toString(GetParam());
  EXPECT_LT(tight, toleranceFor(GetParam())) << sim::toString(GetParam());
  // Measured (seeds 1-10), unbounded -> bounded: box 88 -> 24 mm, cylinder 86 -> 21,
  // sphere 39 -> 14, superellipsoid 55 -> 22 (31 with eq. 3 alone).
  EXPECT_LT(tight, loose) << sim::toString(GetParam());
  // The distances keep the surface on the points that eq. 3's volume factor lets the fit
  // cut through.
  EXPECT_LT(surface, eq3_surface) << sim::toString(GetParam());
}

// Boxes, cylinders and spheres seen the same way at 1 cm range noise (the suites' other
// level), seeds 1-10: within 3 cm (measured 26.4, 23.7 and 10.1 mm), no outside point
// inside a fit.
TEST(FitBounds, OneSidedViewsAtOneCentimetre) {
  for (const sim::NoveltyKind kind :
       {sim::NoveltyKind::kBox, sim::NoveltyKind::kCylinder, sim::NoveltyKind::kSphere}) {
    double tight = 0.0;
    int n = 0, violations = 0;
    for (std::uint64_t seed = 1; seed <= 10; ++seed) {
      const BoundedCase c = fitStanding(kind, seed, 0.0001);
      if (!c.fitted) continue;
      ++n;
      tight += c.bounded_error;
      violations += c.violations;
    }
    ASSERT_GE(n, 3) << sim::toString(kind);
    tight /= n;
    std::printf("%s at 1 cm: %d fits, semi-axis error %.1f mm\n", sim::toString(kind).c_str(), n,
                1000 * tight);
    EXPECT_EQ(violations, 0) << sim::toString(kind);
    EXPECT_LT(tight, 0.03) << sim::toString(kind);
  }
}

INSTANTIATE_TEST_SUITE_P(Kinds, BoundedKind,
                         ::testing::Values(sim::NoveltyKind::kBox, sim::NoveltyKind::kCylinder,
                                           sim::NoveltyKind::kSphere,
                                           sim::NoveltyKind::kSuperellipsoid));

// A door leaf (4 cm thick) that swung, seen from one side at the paper's noise (seeds 1-10):
// its points are one flat face, so nothing observed says how deep the object is, and eq. 3
// alone grows the depth into the space hidden behind it. The fit keeps the thinnest leaf
// the points allow: about the true 2 cm half thickness, within the noise.
TEST(FitBounds, FlatViewsOfDoorLeavesStayThin) {
  int n = 0;
  double thickest = 0.0, error = 0.0;
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    const BoundedCase c = fitStanding(sim::NoveltyKind::kDoorAngle, seed);
    if (!c.fitted) continue;
    ++n;
    thickest = std::max(thickest, c.thinnest);
    error += c.bounded_error;
    EXPECT_EQ(c.violations, 0) << "seed " << seed;
  }
  ASSERT_GE(n, 3);
  std::printf("door leaves: %d fitted, thickest half thickness %.1f mm, semi-axis error %.1f mm\n",
              n, 1000 * thickest, 1000 * error / n);
  // Without the rule the thickest came out at 65 mm (7 leaves fitted, error 119 mm).
  EXPECT_LT(thickest, 0.04);
  // The rest of the error is mostly the leaves' tops, above the sweep's reach.
  EXPECT_LT(error / n, 0.116);
}

// The rule itself: a noisy flat patch cuts the depth of a block fitted to it to the patch's
// own half thickness on the patch's plane; a curved view, a fit already that thin, or one
// whose axes are turned away from the plane's normal are left alone.
TEST(FitBounds, OnlyFlatViewsCutTheirFitsDepth) {
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.01);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Points3d patch;  // a 0.9 x 2 m leaf 4 cm thick, its normal along x, centred at (2, 0, 1)
  for (int k = 0; k < 2000; ++k)
    patch.emplace_back(2.0 + 0.02 * u(rng) + noise(rng), 0.45 * u(rng), 1.0 + u(rng));
  Superquadric block = makeSq({0.3, 0.45, 1.0}, 0.1, 0.1, {0, 0, 0}, {2.25, 0.0, 1.0});
  ASSERT_TRUE(thinToFlatView(patch, 0.01, 0.005, &block));
  EXPECT_NEAR(block.a.x(), 0.02, 0.005);  // sqrt(3) x the noise-free spread
  EXPECT_NEAR(block.position.x(), 2.0, 0.005);
  EXPECT_DOUBLE_EQ(block.a.y(), 0.45);
  EXPECT_DOUBLE_EQ(block.a.z(), 1.0);
  EXPECT_FALSE(thinToFlatView(patch, 0.01, 0.005, &block));  // already that thin
  // Noise alone is no thickness: the floor on the half thickness holds.
  Superquadric again = makeSq({0.3, 0.45, 1.0}, 0.1, 0.1, {0, 0, 0}, {2.25, 0.0, 1.0});
  ASSERT_TRUE(thinToFlatView(patch, 0.05, 0.005, &again));
  EXPECT_DOUBLE_EQ(again.a.x(), 0.005);
  // A fit turned 45 degrees about up from the plane's normal is not cut.
  Superquadric turned = makeSq({0.3, 0.45, 1.0}, 0.1, 0.1, {M_PI / 4, 0.0, 0.0}, {2.25, 0.0, 1.0});
  EXPECT_FALSE(thinToFlatView(patch, 0.01, 0.005, &turned));
  EXPECT_DOUBLE_EQ(turned.a.x(), 0.3);
  // The visible half of a cylinder (radius 0.3 m) is not flat.
  Points3d half;
  for (int k = 0; k < 2000; ++k) {
    const double t = M_PI / 2 * u(rng);
    half.emplace_back(2.0 - 0.3 * std::cos(t) + noise(rng), 0.3 * std::sin(t), 1.0 + u(rng));
  }
  Superquadric cylinder = makeSq({0.3, 0.3, 1.0}, 0.1, 1.0, {0, 0, 0}, {2.0, 0.0, 1.0});
  EXPECT_FALSE(thinToFlatView(half, 0.01, 0.005, &cylinder));
  EXPECT_DOUBLE_EQ(cylinder.a.x(), 0.3);
}

// One scan line is no flat view: a tilting laser's line over the corner of a box lies in a
// plane through the sensor (range noise moves its returns along their rays, within that
// plane), the plane of the line and not a face of the box. Told the origin, the rule leaves
// the fit's height alone; a face seen at an angle from the same origin is still cut.
TEST(FitBounds, OneScanLineIsNoFlatView) {
  std::mt19937 rng(11);
  std::normal_distribution<double> range_noise(0.0, 0.032);
  const Eigen::Vector3d origin(0.0, 0.0, 0.6);
  // One line 0.31 m below the sensor, 5.6 m away, across two faces of a box at 45 degrees.
  const double elevation = std::atan2(-0.31, 5.6);
  Points3d line;
  for (int k = 0; k < 34; ++k) {
    const double s = -0.4 + 0.8 * k / 33.0;  // along the faces: a corner at s = 0
    const Eigen::Vector3d on_box(5.6 + 0.3 * std::abs(s), s, 0.0);
    const double azimuth = std::atan2(on_box.y(), on_box.x());
    const Eigen::Vector3d ray(std::cos(elevation) * std::cos(azimuth),
                              std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
    const double range = on_box.head<2>().norm() / std::cos(elevation);
    line.push_back(origin + (range + range_noise(rng)) * ray);
  }
  // A box fitted upright to it: 0.29 m tall to the floor.
  const Superquadric box = makeSq({0.3, 0.4, 0.145}, 0.1, 0.1, {0, 0, 0}, {5.75, 0.0, 0.145});
  Superquadric without_origin = box, with_origin = box;
  // Without the origin the line's plane (horizontal) passes for a face seen square on, and
  // the box is cut to a sheet 1 cm thick: the flattened fits the rule had made.
  EXPECT_TRUE(thinToFlatView(line, 0.032, 0.005, &without_origin));
  EXPECT_LT(without_origin.a.z(), 0.01);
  EXPECT_FALSE(thinToFlatView(line, 0.032, 0.005, &with_origin, &origin));
  EXPECT_DOUBLE_EQ(with_origin.a.z(), 0.145);
  // A leaf's face 2 m wide and 2 m tall seen from the same origin 10 degrees off its plane:
  // a flat view.
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Eigen::Vector3d along(std::cos(10.0 * M_PI / 180.0), std::sin(10.0 * M_PI / 180.0), 0.0);
  const Eigen::Vector3d normal(-along.y(), along.x(), 0.0);
  const Eigen::Vector3d centre = origin + Eigen::Vector3d(4.0, 0.0, 0.4);
  Points3d face;
  for (int k = 0; k < 500; ++k)
    face.push_back(centre + along * u(rng) + Eigen::Vector3d(0, 0, u(rng)) +
                   normal * 0.01 * range_noise(rng) / 0.032);
  Superquadric leaf = makeSq({1.0, 0.3, 1.0}, 0.1, 0.1, {std::atan2(along.y(), along.x()), 0, 0},
                             centre + 0.3 * normal);
  EXPECT_TRUE(thinToFlatView(face, 0.01, 0.005, &leaf, &origin));
  EXPECT_LT(leaf.a.y(), 0.03);
}
