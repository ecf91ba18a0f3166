// Compact groups among the points outlier removal took (sparse_groups.h), with known answers:
// the rule on constructed point sets (a far patch is a segment, a streak along an edge and
// scattered returns are not, a group touching a segment joins it), and simulated door leaves
// seen far away at a grazing angle (door-only scenes, at 3.2 cm and 1 cm range noise, from the
// reference pose and from a shifted one) that are found with the rule and missed without it;
// and the free-standing groups among the kept points (an upright strip is one, a piece of a scan
// line is not; a far leaf of the simulated suite no selected Gaussian owns is found by them).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "novelty_detection/pipeline.h"
#include "novelty_detection/segmentation/sparse_groups.h"
#include "novelty_detection/sim/scene.h"

using namespace novelty_detection;

namespace {

const Eigen::Vector3f kOrigin(0.f, 0.f, 1.f);

/// Appends p to the cloud and returns its index.
int add(Cloud& cloud, const Eigen::Vector3f& p) {
  cloud.push_back(PointT(p.x(), p.y(), p.z()));
  return static_cast<int>(cloud.size()) - 1;
}

/// A grid of nx x nz points `spacing` apart on the vertical plane x = x0, from (y0, z0).
Indices patch(Cloud& cloud, float x0, float y0, float z0, int nx, int nz, float spacing) {
  Indices out;
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < nz; ++j)
      out.push_back(add(cloud, {x0, y0 + i * spacing, z0 + j * spacing}));
  return out;
}

const auto kEverywhereChanged = [](const Eigen::Vector3f&) { return true; };

/// The best IoU of a segment of `r` with the scene's changed points (all labelled objects as
/// one), and the static points `r` labels.
struct Found {
  double iou = 0.0;
  std::size_t false_points = 0;
};
Found found(const sim::ScenePair& s, const Result& r) {
  Found f;
  std::size_t changed = 0;
  for (int label : s.current_labels) changed += label > 0;
  for (const Segment& seg : r.segments) {
    std::size_t both = 0;
    for (int i : seg.indices) both += s.current_labels[static_cast<std::size_t>(i)] > 0;
    f.iou = std::max(f.iou, static_cast<double>(both) /
                                static_cast<double>(seg.indices.size() + changed - both));
  }
  for (std::size_t i = 0; i < s.current.size(); ++i)
    f.false_points += s.current_labels[i] == 0 && r.labels[i] > 0;
  return f;
}

}  // namespace

TEST(SparseGroups, SpacingRatioIsTheMedianSpacingPerMetreOfRange) {
  Cloud cloud;
  Indices points;
  std::vector<double> kth;
  // Ranges 1, 2, 3, 4, 5 m with spacings giving ratios 0.01, 0.02, 0.03, 0.04, 0.05.
  for (int k = 1; k <= 5; ++k) {
    points.push_back(add(cloud, kOrigin + Eigen::Vector3f(static_cast<float>(k), 0.f, 0.f)));
    kth.push_back(0.01 * k * k);
  }
  EXPECT_NEAR(spacingRatio(cloud, points, kth, kOrigin), 0.03, 1e-6);
  EXPECT_EQ(spacingRatio(cloud, {}, {}, kOrigin), 0.0);
}

TEST(SparseGroups, FarPatchIsASegmentStreakAndScatteredReturnsAreNot) {
  // The sweep's spacing: 0.025 m per metre of range, linked within 2.5 times that.
  const double ratio = 0.025, link_factor = 2.5;
  Cloud cloud;
  // A patch 6 m away sampled at its range's spacing (0.15 m): 6 x 8 points.
  const Indices far_patch = patch(cloud, 6.f, -0.4f, 0.2f, 6, 8, 0.15f);
  // A streak of mixed returns along a vertical edge 5 m away: 30 points in a line.
  Indices streak;
  for (int k = 0; k < 30; ++k) streak.push_back(add(cloud, {5.f, 2.f, 0.1f + 0.06f * k}));
  // Scattered returns: 30 points at least 1 m apart, 3 to 9 m away.
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  Indices scattered;
  while (scattered.size() < 30) {
    const Eigen::Vector3f p(3.f + 3.f * (u(rng) + 1.f), 6.f * u(rng), 1.5f + 1.4f * u(rng));
    bool apart = (p - Eigen::Vector3f(6.f, 0.f, 0.8f)).norm() > 2.f &&
                 (p - Eigen::Vector3f(5.f, 2.f, 1.f)).norm() > 2.f;
    for (int i : scattered) apart = apart && (cloud[i].getVector3fMap() - p).norm() > 1.f;
    if (apart) scattered.push_back(add(cloud, p));
  }
  Indices removed = far_patch;
  removed.insert(removed.end(), streak.begin(), streak.end());
  removed.insert(removed.end(), scattered.begin(), scattered.end());
  std::sort(removed.begin(), removed.end());
  const SparseGroups g =
      sparseNovelGroups(cloud, removed, {}, kEverywhereChanged, kOrigin, ratio, link_factor, 20);
  ASSERT_EQ(g.segments.size(), 1u);
  EXPECT_EQ(g.segments[0], far_patch);
  EXPECT_TRUE(g.joined.empty());
  // Not changed (on the map, or in space the reference never saw through): nothing.
  const auto nowhere = [](const Eigen::Vector3f&) { return false; };
  EXPECT_TRUE(sparseNovelGroups(cloud, removed, {}, nowhere, kOrigin, ratio, link_factor, 20)
                  .segments.empty());
  // Fewer points than a segment needs.
  EXPECT_TRUE(
      sparseNovelGroups(cloud, removed, {}, kEverywhereChanged, kOrigin, ratio, link_factor, 49)
          .segments.empty());
  // Without a spacing there is no rule.
  EXPECT_TRUE(
      sparseNovelGroups(cloud, removed, {}, kEverywhereChanged, kOrigin, 0.0, link_factor, 20)
          .segments.empty());
}

TEST(SparseGroups, GroupTouchingASegmentJoinsIt) {
  const double ratio = 0.025, link_factor = 2.5;
  Cloud cloud;
  // Two segments 4 m away; a sparse strip of 8 points continues the second one.
  const Indices first = patch(cloud, 4.f, -2.f, 0.2f, 5, 5, 0.05f);
  const Indices second = patch(cloud, 4.f, 1.f, 0.2f, 5, 5, 0.05f);
  const Indices strip = patch(cloud, 4.f, 1.2f + 0.2f, 0.2f, 2, 4, 0.2f);
  const SparseGroups g = sparseNovelGroups(cloud, strip, {first, second}, kEverywhereChanged,
                                           kOrigin, ratio, link_factor, 20);
  ASSERT_EQ(g.joined.size(), 2u);
  EXPECT_TRUE(g.joined[0].empty());
  EXPECT_EQ(g.joined[1], strip);
  EXPECT_TRUE(g.segments.empty());
}

// Door-only simulated scenes whose leaf stands 3-5.5 m away, seen at a grazing angle by a few
// tilt lines: outlier removal takes most of it. With the rule it is found (best IoU >= 0.5),
// without it missed, at both noise levels and from a shifted pose, and the rule adds no
// false segment.
TEST(SparseGroups, SparseDoorLeavesFoundAtBothNoiseLevelsAndFromAShiftedPose) {
  struct Case {
    unsigned seed;
    double noise_variance_m2;
    bool shifted;
  };
  const std::vector<Case> cases = {{10, 0.001, false},  {20, 0.001, false},  {29, 0.001, false},
                                   {10, 0.0001, false}, {20, 0.0001, false}, {44, 0.0001, false},
                                   {20, 0.001, true},   {27, 0.001, true},   {20, 0.0001, true}};
  Params with;
  with.superquadric.enabled = false;
  Params without = with;
  without.segmentation.sparse_groups = false;
  for (const Case& c : cases) {
    sim::SceneConfig config;
    config.seed = c.seed;
    config.novelty_kinds = {sim::NoveltyKind::kDoorAngle};
    config.laser.noise_variance_m2 = c.noise_variance_m2;
    if (c.shifted) config.pose_offset = Eigen::Vector3d(0.2, 0.1, 5.0 * M_PI / 180.0);
    const sim::ScenePair s = sim::generateScenePair(config);
    double iou[2] = {0.0, 0.0};
    std::size_t false_points[2] = {0, 0}, segments[2] = {0, 0};
    for (int k = 0; k < 2; ++k) {
      Pipeline pipeline(k == 0 ? with : without);
      pipeline.setReference(s.reference);
      const Result r = pipeline.detect(s.current);
      segments[k] = r.segments.size();
      std::size_t restored = 0;
      for (const auto& [stage, n] : r.point_counts)
        if (stage == "sparse_group_points") restored = n;
      if (k == 0) EXPECT_GT(restored, 0u) << "seed " << c.seed;
      if (k == 1) EXPECT_EQ(restored, 0u) << "seed " << c.seed;
      const Found f = found(s, r);
      iou[k] = f.iou;
      false_points[k] = f.false_points;
    }
    std::printf(
        "door seed %u, noise %.4f m2%s: IoU %.2f with the rule, %.2f without; false "
        "points %zu / %zu; segments %zu / %zu\n",
        c.seed, c.noise_variance_m2, c.shifted ? ", shifted pose" : "", iou[0], iou[1],
        false_points[0], false_points[1], segments[0], segments[1]);
    EXPECT_GE(iou[0], 0.5) << "seed " << c.seed;
    EXPECT_LT(iou[1], 0.5) << "seed " << c.seed;
    EXPECT_LE(false_points[0], false_points[1] + 5) << "seed " << c.seed;
    EXPECT_LE(segments[0], segments[1] + 1) << "seed " << c.seed;
  }
}

// Free-standing groups (GroupShape::kStands) over kept points: at 5 m (spacing 0.125 m) a
// narrow upright strip, 2 points across and 14 tilt lines high (a far door leaf seen at a
// grazing angle), is a segment; it spreads in one direction only, so the outliers' test would
// not take it. A piece of one scan line (28 points 0.02 m apart, a surface a pose error moved)
// is no segment under either test's size and shape bounds.
TEST(SparseGroups, AnUprightStripOfKeptPointsStandsAScanLinesPieceDoesNot) {
  const double ratio = 0.025, link_factor = 2.5;
  Cloud cloud;
  Indices loose = patch(cloud, 5.f, 0.f, 0.f, 2, 14, 0.125f);
  const std::size_t strip = loose.size();
  for (int i = 0; i < 28; ++i) loose.push_back(add(cloud, {5.f, 2.f + 0.02f * i, 0.75f}));
  const SparseGroups standing = sparseNovelGroups(cloud, loose, {}, kEverywhereChanged, kOrigin,
                                                  ratio, link_factor, 20, GroupShape::kStands);
  ASSERT_EQ(standing.segments.size(), 1u);
  EXPECT_EQ(standing.segments[0].size(), strip);
  EXPECT_EQ(standing.segments[0].back(), loose[strip - 1]);
  const SparseGroups spread =
      sparseNovelGroups(cloud, loose, {}, kEverywhereChanged, kOrigin, ratio, link_factor, 20);
  for (const Indices& s : spread.segments) EXPECT_NE(s.size(), strip);
}

// Suite seed 6, scene 27 (a development seed): a door leaf 4.9 m away seen at a grazing angle,
// 123 points of which 90 lie farther than tau from the map, is owned by no selected Gaussian.
// Its kept points stand in free space over many tilt lines: a free-standing group, found with
// the rule (IoU >= 0.6), not without (IoU 0), with no other point labelled either way.
TEST(SparseGroups, AFarLeafNoGaussianOwnsIsAFreeStandingGroup) {
  const sim::ScenePair s = sim::generateScenePair(sim::suiteSceneConfig(27, 6));
  Params with;
  with.superquadric.enabled = false;
  Params without = with;
  without.segmentation.free_groups = false;
  Found f[2];
  for (int k = 0; k < 2; ++k) {
    Pipeline pipeline(k == 0 ? with : without);
    pipeline.setReference(s.reference);
    f[k] = found(s, pipeline.detect(s.current));
  }
  std::printf("far leaf: IoU %.2f with free groups, %.2f without; false points %zu / %zu\n",
              f[0].iou, f[1].iou, f[0].false_points, f[1].false_points);
  EXPECT_GE(f[0].iou, 0.6);
  EXPECT_LT(f[1].iou, 0.1);
  EXPECT_EQ(f[0].false_points, 0u);
}
