// Door leaves swung into space the reference could not see (hidden_segments.h), with known
// answers: what is left of the old leaf about the same hinge crosses the new leaf's plane and
// does not make it a continuation of the map; a wall beside a leaf that left is still a wall; the
// plane of one scan line (through the sensor) is no surface; a leaf's own surface continues into
// its hidden part past the growth cap, but not along a mapped wall; and on simulated suite scenes
// (suite seeds 4 and 6) leaves missed without these rules are found.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <map>
#include <random>
#include <vector>

#include "novelty_detection/segmentation/hidden_segments.h"
#include "novelty_detection/sim/scene.h"
#include "novelty_detection/visibility/visibility.h"
#include "sim_objects.h"

using namespace novelty_detection;

namespace {

constexpr double kTau = 0.05;

/// Points of a vertical leaf hinged at `hinge` (x, y), `angle` from the +x axis, from
/// `from` to `to` metres along it, 0.02 m apart, z in [0, 2].
void addLeaf(Cloud* cloud, double hx, double hy, double angle_deg, double from, double to) {
  const double a = angle_deg * M_PI / 180.0;
  for (double s = from; s <= to + 1e-9; s += 0.02)
    for (double z = 0.0; z <= 2.0 + 1e-9; z += 0.02)
      cloud->push_back(PointT(static_cast<float>(hx + s * std::cos(a)),
                              static_cast<float>(hy + s * std::sin(a)), static_cast<float>(z)));
}

/// A wall in the plane y = 0 from x0 to x1, 0.02 m grid, z in [0, 2].
void addWall(Cloud* cloud, double x0, double x1) {
  for (double x = x0; x <= x1 + 1e-9; x += 0.02)
    for (double z = 0.0; z <= 2.0 + 1e-9; z += 0.02)
      cloud->push_back(PointT(static_cast<float>(x), 0.f, static_cast<float>(z)));
}

struct Context {
  NearestNeighbourIndex structure;
  std::vector<std::uint8_t> gone;
  HiddenSegmentContext ctx;
  Context(const Cloud& reference, const Cloud& current, std::vector<std::uint8_t> gone_flags)
      : gone(std::move(gone_flags)) {
    structure.build(reference);
    ctx.current = &current;
    ctx.structure = &structure;
    ctx.gone = &gone;
    ctx.tau = kTau;
  }
};

Indices all(const Cloud& c) {
  Indices out;
  for (std::size_t i = 0; i < c.size(); ++i) out.push_back(static_cast<int>(i));
  return out;
}

/// Share of the door's points labelled, the most of them in one segment, and labelled
/// points of the static scene.
struct DoorFound {
  long leaf = 0, best = 0, false_points = 0;
};

DoorFound detectDoor(int seed, int index, double noise_variance_m2 = 0.0) {
  sim::SceneConfig config = sim::suiteSceneConfig(index, seed);
  if (noise_variance_m2 > 0.0) config.laser.noise_variance_m2 = noise_variance_m2;
  const sim::ScenePair s = sim::generateScenePair(config);
  int door = 0;
  for (const auto& o : s.objects)
    if (o.kind == sim::NoveltyKind::kDoorAngle) door = o.id;
  EXPECT_GT(door, 0);
  const Result r = sim_objects::detectLabels(s);
  DoorFound f;
  std::map<int, long> per_segment;
  for (std::size_t i = 0; i < r.labels.size(); ++i) {
    f.leaf += s.current_labels[i] == door;
    if (s.current_labels[i] == door && r.labels[i] > 0) ++per_segment[r.labels[i]];
    f.false_points += s.current_labels[i] == 0 && r.labels[i] > 0;
  }
  for (const auto& [id, n] : per_segment) f.best = std::max(f.best, n);
  return f;
}

}  // namespace

// A leaf that swung from 4 to 30 degrees about a hinge at the origin, on a wall y = 0 that
// ends 0.3 m before the hinge. The reference holds the wall and the old leaf; the old leaf
// beyond 0.15 m of the hinge has disappeared, its part near the hinge is still mapped (the
// new leaf hides it from the sweep) and is all the structure about the new leaf. Over a third
// of it lies within hidden_plane_factor * tau of the new leaf's plane (past
// hidden_max_coplanar), but its own plane crosses the leaf's and runs on into the part that
// disappeared: what is left of the old leaf is no map the new one continues.
TEST(SwungLeaves, WhatIsLeftOfTheOldLeafIsNoMapTheNewOneContinues) {
  Cloud reference;
  addWall(&reference, -1.0, -0.3);
  const std::size_t wall = reference.size();
  addLeaf(&reference, 0.0, 0.0, 4.0, 0.02, 0.88);
  std::vector<std::uint8_t> gone(reference.size(), 0);
  for (std::size_t i = wall; i < reference.size(); ++i)
    gone[i] = std::hypot(reference[i].x, reference[i].y) > 0.15;
  Cloud current;
  addLeaf(&current, 0.0, 0.0, 30.0, 0.06, 0.88);
  Context c(reference, current, gone);
  const SegmentationParams params;
  const Indices leaf = all(current);
  const std::vector<Visibility> vis(leaf.size(), Visibility::kOccluded);
  const HiddenSegmentEvidence e = measureHiddenSegment(c.ctx, leaf, vis, params);
  // What lies on the leaf's plane, whatever its own surface.
  const double on_plane = params.hidden.plane_factor * kTau;
  const Eigen::Vector3d n(-std::sin(30.0 * M_PI / 180.0), std::cos(30.0 * M_PI / 180.0), 0.0);
  std::vector<int> near;
  std::vector<char> seen(reference.size(), 0);
  long ring = 0, on = 0;
  for (int i : leaf) {
    near.clear();
    c.structure.withinIds(current[i].getVector3fMap(), params.hidden.ring_factor * kTau, &near);
    for (int j : near) {
      if (seen[j] || gone[j]) continue;
      seen[j] = 1;
      ++ring;
      on += std::abs(n.dot(reference[j].getVector3fMap().cast<double>())) <= on_plane;
    }
  }
  std::printf("ring %d (%ld by brute force), on the plane %ld, coplanar %d\n", e.ring, ring, on,
              e.ring_coplanar);
  EXPECT_EQ(e.ring, ring);
  EXPECT_GE(on, params.hidden.max_coplanar * ring);  // the case the rule must get right
  EXPECT_EQ(e.ring_coplanar, 0);
  EXPECT_FALSE(revealedSurface(c.ctx, leaf, params));
}

// A patch of wall revealed where an open leaf stood (0.3 <= x <= 0.7 on the wall y = 0,
// the leaf perpendicular to it at x = 0.25, gone) continues the wall around it, and the
// leaf's disappearance beside it takes nothing from that. (Here the wall's share holds
// however its own surface is measured; that it is measured without the leaf that left
// decides HiddenSegments.DoorLeafDoesNotGrowOverTheRecessItRevealed, seed 5 scene 20.)
TEST(SwungLeaves, AWallBesideALeafThatLeftIsStillAWall) {
  Cloud reference;
  addWall(&reference, -1.0, 0.28);
  addWall(&reference, 0.72, 2.0);
  const std::size_t wall = reference.size();
  addLeaf(&reference, 0.25, 0.02, 90.0, 0.0, 0.86);
  std::vector<std::uint8_t> gone(reference.size(), 0);
  for (std::size_t i = wall; i < reference.size(); ++i) gone[i] = 1;
  Cloud current;
  addWall(&current, 0.3, 0.7);
  Context c(reference, current, gone);
  const SegmentationParams params;
  EXPECT_TRUE(revealedSurface(c.ctx, all(current), params));
  // Nor is the revealed patch novel on its own.
  const Indices patch = all(current);
  const std::vector<Visibility> vis(patch.size(), Visibility::kOccluded);
  const HiddenSegmentEvidence e = measureHiddenSegment(c.ctx, patch, vis, params);
  std::printf("revealed patch: ring %d, coplanar %d\n", e.ring, e.ring_coplanar);
  EXPECT_FALSE(hiddenSegmentIsNovel(e, kTau, params));
}

// One scan line of a tilting laser across a wall 3 m away: its points, moved along their
// rays by range noise (sigma 2 cm, seeded), lie in the scan's plane through the sensor. That
// plane is no surface: its distance from the sensor is within tau. A patch of the same wall
// seen at 80 degrees incidence is one (0.5 m from the sensor).
TEST(SwungLeaves, AScanLinesOwnPlaneIsNoSurface) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.02);
  const Eigen::Vector3d origin(0.0, 0.0, 0.6);
  Cloud current;
  const double tilt = 10.0 * M_PI / 180.0;
  for (double az = -0.35; az <= 0.35; az += 0.0044) {  // a wall at x = 3
    // The scan plane, turned by the tilt about the y axis.
    const Eigen::Vector3d dir(std::cos(tilt) * std::cos(az), std::sin(az),
                              std::sin(tilt) * std::cos(az));
    const double r = 3.0 / dir.x() + noise(rng);
    const Eigen::Vector3d p = origin + r * dir;
    current.push_back(
        PointT(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
  }
  current.sensor_origin_ = Eigen::Vector4f(0.f, 0.f, 0.6f, 1.f);
  RangeImage image;
  image.build(current, {}, origin.cast<float>(), rangeImageConfig(VisibilityParams()));
  HiddenSegmentContext ctx;
  ctx.current = &current;
  ctx.current_image = &image;
  ctx.tau = kTau;
  const Indices line = all(current);
  const std::vector<Visibility> vis(line.size(), Visibility::kOccluded);
  const SegmentationParams params;
  const HiddenSegmentEvidence e = measureHiddenSegment(ctx, line, vis, params);
  std::printf("scan line: width %.3f, thickness %.4f, plane %.3f m from the sensor\n", e.width_m,
              e.thickness_m, e.origin_offset_m);
  ASSERT_GE(e.origin_offset_m, 0.0);
  EXPECT_LE(e.origin_offset_m, kTau);
  // The evidence of a door leaf with that plane is no novel segment; 0.5 m off, it is.
  HiddenSegmentEvidence leaf;
  leaf.points = leaf.surface = 200;
  leaf.occluded = 190;
  leaf.width_m = 2.0 * kTau;
  leaf.thickness_m = 0.5 * kTau;
  leaf.ring = 100;
  leaf.ring_coplanar = 10;
  leaf.past = leaf.on = 150;
  leaf.origin_offset_m = e.origin_offset_m;
  EXPECT_FALSE(hiddenSegmentIsNovel(leaf, kTau, params));
  leaf.origin_offset_m = 0.5;  // a wall 3 m away seen at 80 degrees: 3 cos(80) = 0.52 m
  EXPECT_TRUE(hiddenSegmentIsNovel(leaf, kTau, params));
}

// A leaf (plane y = 0.5, x in [0, 0.9]) of which the map saw 0.2 m: that part is the novel
// segment (11 columns of points), the rest is hidden. The hidden part continues the
// segment's own plane and joins it whole, past the growth cap (1x the segment's points),
// which holds without the context. Where a mapped wall lies in the leaf's plane (x >= 0.6),
// the hidden points along it do not join.
TEST(SwungLeaves, ALeafsOwnSurfaceContinuesPastTheCap) {
  Cloud current;
  addLeaf(&current, 0.0, 0.5, 0.0, 0.0, 0.9);  // 46 columns of 101 points
  Indices seg, hidden;
  for (std::size_t i = 0; i < current.size(); ++i)
    (current[i].x <= 0.2f + 1e-4f ? seg : hidden).push_back(static_cast<int>(i));
  const SegmentationParams params;
  const auto grow = [&](const Cloud* reference) {
    std::vector<Indices> segments{seg};
    if (!reference) {
      growIntoHidden(current, &segments, hidden, 0.03, 1.0);
      return segments[0].size();
    }
    Context c(*reference, current, std::vector<std::uint8_t>(reference->size(), 0));
    growIntoHidden(current, &segments, hidden, 0.03, 1.0, &c.ctx, &params);
    return segments[0].size();
  };
  Cloud far_wall;  // mapped structure away from the leaf: a wall at y = 3
  addWall(&far_wall, -1.0, 2.0);
  for (auto& p : far_wall) p.y = 3.f;
  const std::size_t whole = grow(&far_wall), capped = grow(nullptr);
  Cloud wall_in_plane = far_wall;
  for (double x = 0.6; x <= 2.0; x += 0.02)
    for (double z = 0.0; z <= 2.0 + 1e-9; z += 0.02)
      wall_in_plane.push_back(PointT(static_cast<float>(x), 0.5f, static_cast<float>(z)));
  const std::size_t by_wall = grow(&wall_in_plane);
  std::printf("segment %zu of %zu points: %zu with the context, %zu without, %zu by a wall\n",
              seg.size(), current.size(), whole, capped, by_wall);
  EXPECT_EQ(whole, current.size());
  EXPECT_EQ(capped, 2 * seg.size());
  // The wall's points within 2 tau of the hidden ones stop the growth before x = 0.6 - 2 tau.
  EXPECT_GE(by_wall, 2 * seg.size());
  EXPECT_LE(by_wall, static_cast<std::size_t>(101 * 26));  // x <= 0.5
}

// Simulated suite scenes at the paper's noise (sigma 3.2 cm) and at 1 cm, none of them used
// elsewhere in the tests (seed 6 scene 10 is seen from a shifted pose). Without the rules of
// this file, at 3.2 cm: suite seed 4 scene 24 (a leaf swung from 4 to 56 degrees into the old
// leaf's shadow, 1,178 points) has none found, the old leaf's part about the hinge counting
// as map it continues; seed 6 scene 10 (a leaf at 90 degrees 5.4 m away, 117 points in a strip
// 0.2 m wide, narrower than tau) none; seed 6 scene 20 (a leaf closed from 86 to 13 degrees)
// 460 of 1,243, its visible part grown into its hidden part up to the cap only.
TEST(SwungLeaves, LeavesFoundOnSuiteScenes) {
  struct Case {
    int seed, index;
    double share;  // of the leaf in one segment, at least
  };
  for (const Case& k : {Case{4, 24, 0.55}, Case{6, 10, 0.7}, Case{6, 20, 0.6}}) {
    const DoorFound f = detectDoor(k.seed, k.index);
    std::printf("seed %d scene %d: leaf %ld points, %ld in one segment, %ld false points\n", k.seed,
                k.index, f.leaf, f.best, f.false_points);
    EXPECT_GE(f.best, k.share * f.leaf) << "seed " << k.seed << " scene " << k.index;
    EXPECT_LE(f.false_points, f.leaf / 20) << "seed " << k.seed << " scene " << k.index;
  }
  // The same scenes at 1 cm of range noise: 0 and 467 of the leaves' points in one segment
  // without these rules; the far leaf was found either way.
  for (const Case& k : {Case{4, 24, 0.65}, Case{6, 10, 0.7}, Case{6, 20, 0.75}}) {
    const DoorFound f = detectDoor(k.seed, k.index, 0.0001);
    std::printf("at 1 cm: seed %d scene %d: leaf %ld points, %ld in one segment, %ld false\n",
                k.seed, k.index, f.leaf, f.best, f.false_points);
    EXPECT_GE(f.best, k.share * f.leaf) << "1 cm, seed " << k.seed << " scene " << k.index;
    EXPECT_LE(f.false_points, f.leaf / 20) << "1 cm, seed " << k.seed << " scene " << k.index;
  }
}
