// The segment-level rule for candidates hidden from the reference (hidden_segments.h), with
// known answers: the rule's clauses on measured evidence; door leaves swung into space the
// old leaf hid (simulated suite scenes, seed 1) are novel with the rule and missed without
// it; the wall revealed behind a moved box in a corner and the surfaces revealed behind a
// removed box stay not novel, also when the sweep's pose is off; a moved box reaching into the
// old box's shadow is found whole.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <map>
#include <utility>

#include "novelty_detection/pipeline.h"
#include "novelty_detection/segmentation/hidden_segments.h"
#include "novelty_detection/sim/scene.h"
#include "sim_objects.h"

using namespace novelty_detection;

namespace {

HiddenSegmentEvidence doorLike(double tau) {
  HiddenSegmentEvidence e;
  e.points = 200;
  e.surface = 200;
  e.occluded = 190;
  e.width_m = 1.5 * tau;
  e.thickness_m = 0.3 * tau;
  e.ring = 100;
  e.ring_coplanar = 10;
  e.past = 150;
  e.on = 250;
  return e;
}

struct Counts {
  long object = 0, found = 0, false_points = 0;
};

// Points of object `id` (all objects when id = 0) labelled novel, and labelled points on
// the static scene.
Counts count(const Result& r, const std::vector<int>& truth, int id) {
  Counts c;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const bool on = id > 0 ? truth[i] == id : truth[i] > 0;
    c.object += on;
    c.found += on && r.labels[i] > 0;
    c.false_points += truth[i] == 0 && r.labels[i] > 0;
  }
  return c;
}

/// Detection of `s` with the default rules (superquadrics off) and with `rule` switched off.
std::pair<Result, Result> withAndWithout(const sim::ScenePair& s, bool HiddenParams::*rule,
                                         double object_share = SegmentationParams().object_share) {
  Params with;
  with.superquadric.enabled = false;
  with.segmentation.object_share = object_share;
  Params without = with;
  without.segmentation.hidden.*rule = false;
  Pipeline a(with), b(without);
  a.setReference(s.reference);
  b.setReference(s.reference);
  return {a.detect(s.current), b.detect(s.current)};
}

int doorId(const sim::ScenePair& s) {
  for (const auto& o : s.objects)
    if (o.kind == sim::NoveltyKind::kDoorAngle) return o.id;
  return 0;
}

/// The rule's context for `current` against `reference`: all of it structure, none gone.
struct MappedStructure {
  NearestNeighbourIndex structure;
  std::vector<std::uint8_t> gone;
  HiddenSegmentContext ctx;
  MappedStructure(const Cloud& reference, const Cloud& current, double tau)
      : gone(reference.size(), 0) {
    structure.build(reference);
    ctx.current = &current;
    ctx.structure = &structure;
    ctx.gone = &gone;
    ctx.tau = tau;
  }
  MappedStructure(const MappedStructure&) = delete;
  MappedStructure& operator=(const MappedStructure&) = delete;
};

/// A door leaf hinged on the edge of a wall's hole meets the wall along its hinge only: the
/// wall about it crosses its plane (none of it parallel, too little of it on the plane), and
/// the leaf is no revealed surface.
void expectLeafMeetsTheWallAlongItsHingeOnly(const HiddenSegmentContext& ctx, const Indices& leaf,
                                             const SegmentationParams& params) {
  const std::vector<Visibility> vis(leaf.size(), Visibility::kOccluded);
  const HiddenSegmentEvidence e = measureHiddenSegment(ctx, leaf, vis, params);
  std::printf("leaf: ring %d, on its plane %d (%d parallel)\n", e.ring, e.ring_coplanar,
              e.ring_parallel);
  EXPECT_GT(e.ring, 100);
  EXPECT_EQ(e.ring_parallel, 0);
  EXPECT_LT(e.ring_coplanar, params.hidden.max_coplanar * e.ring);
  EXPECT_FALSE(revealedSurface(ctx, leaf, params));
}

}  // namespace

TEST(HiddenSegments, RuleClauses) {
  const double tau = 0.08;
  SegmentationParams p;
  EXPECT_TRUE(hiddenSegmentIsNovel(doorLike(tau), tau, p));
  HiddenSegmentEvidence e = doorLike(tau);
  e.occluded = 90;  // mostly out of the reference's view, not behind something it saw
  EXPECT_FALSE(hiddenSegmentIsNovel(e, tau, p));
  e = doorLike(tau);
  e.width_m = 0.74 * tau;  // a line: no plane
  e.thickness_m = 0.1 * tau;
  EXPECT_FALSE(hiddenSegmentIsNovel(e, tau, p));
  e.width_m = 0.75 * tau;  // a strip 3/4 tau wide, many times as wide as thick: a plane
  EXPECT_TRUE(hiddenSegmentIsNovel(e, tau, p));
  e = doorLike(tau);
  e.thickness_m = 0.5 * e.width_m;  // no flatter across its plane than within it: no plane
  EXPECT_FALSE(hiddenSegmentIsNovel(e, tau, p));
  e = doorLike(tau);
  e.origin_offset_m = tau;  // its plane passes within tau of the sensor: a scan line's own
  EXPECT_FALSE(hiddenSegmentIsNovel(e, tau, p));
  e.origin_offset_m = 1.01 * tau;
  EXPECT_TRUE(hiddenSegmentIsNovel(e, tau, p));
  e = doorLike(tau);
  e.thickness_m = 1.1 * tau;  // not a surface patch
  EXPECT_FALSE(hiddenSegmentIsNovel(e, tau, p));
  e = doorLike(tau);
  e.surface = 159;  // over a fifth of it off its surface's plane: two surfaces or a blob
  EXPECT_FALSE(hiddenSegmentIsNovel(e, tau, p));
  e.surface = 160;
  EXPECT_TRUE(hiddenSegmentIsNovel(e, tau, p));
  e = doorLike(tau);
  e.ring_coplanar = 25;  // a quarter of the structure around continues its plane
  EXPECT_FALSE(hiddenSegmentIsNovel(e, tau, p));
  e.ring_coplanar = 24;
  EXPECT_TRUE(hiddenSegmentIsNovel(e, tau, p));
  e = doorLike(tau);
  e.ring = e.ring_coplanar = 0;  // nothing mapped around: no evidence either way
  EXPECT_FALSE(hiddenSegmentIsNovel(e, tau, p));
  e = doorLike(tau);
  e.past = 83;  // 83 / 333 < 0.25: no free edge (a revealed background surface)
  EXPECT_FALSE(hiddenSegmentIsNovel(e, tau, p));
  e.past = 84;
  EXPECT_TRUE(hiddenSegmentIsNovel(e, tau, p));
}

TEST(HiddenSegments, DoorLeafHiddenByOldLeafIsNovel) {
  // Suite scenes (seed 1) whose door leaf swung into space the old leaf hid from the
  // reference: 7 (31 -> 76 deg, 1088 points), 21 (15 -> 61 deg, 266 points: found since free
  // edges are counted per ray, not per range-image cell) and 27 (3 -> 85 deg,
  // 549 points).
  for (int index : {7, 21, 27}) {
    const sim::ScenePair s = sim::generateScenePair(sim::suiteSceneConfig(index, 1));
    const int door = doorId(s);
    ASSERT_GT(door, 0);
    const auto [ra, rb] = withAndWithout(s, &HiddenParams::segments);
    const Counts on = count(ra, s.current_labels, door);
    const Counts off = count(rb, s.current_labels, door);
    std::printf("scene %d: door %ld points, found %ld with the rule, %ld without\n", index,
                on.object, on.found, off.found);
    EXPECT_EQ(off.found, 0) << "scene " << index;
    EXPECT_GE(on.found, on.object * 6 / 10) << "scene " << index;
    // Floor returns at the leaf's foot, just above the ground band, may join it: as part of
    // the new object, those the old leaf hid from the reference too (measured: 12 points of
    // scene 27's 549, none or one in the others); no more.
    EXPECT_LE(on.false_points, on.object / 40) << "scene " << index;
  }
}

TEST(HiddenSegments, RevealedWallsStayNotNovel) {
  // Suite scene 26 (seed 1): a box moved out of a room corner reveals ~2,700 points of wall
  // the reference could not see, mostly occluded, around which little mapped wall continues:
  // it has no free edge in the current view. The moved box itself is novel.
  const sim::ScenePair s = sim::generateScenePair(sim::suiteSceneConfig(26, 1));
  const Result r = sim_objects::detectLabels(s);
  long revealed = 0, revealed_novel = 0;
  for (std::size_t i = 0; i < r.labels.size(); ++i) {
    revealed += s.current_newly_visible[i];
    revealed_novel += s.current_newly_visible[i] && r.labels[i] > 0;
  }
  const Counts c = count(r, s.current_labels, 0);
  std::printf("scene 26: %ld newly visible points, %ld labelled; object %ld/%ld\n", revealed,
              revealed_novel, c.found, c.object);
  EXPECT_GT(revealed, 2000);
  EXPECT_EQ(revealed_novel, 0);
  EXPECT_EQ(c.false_points, 0);
  EXPECT_GE(c.found, c.object / 2);
  // A removed box read backwards (the reference has it, the current sweep does not): the
  // wall and floor behind it are revealed, nothing is novel.
  Params params;
  params.superquadric.enabled = false;
  for (std::uint64_t seed : {3u, 7u}) {
    sim::SceneConfig config;
    config.seed = seed;
    config.novelty_kinds = {sim::NoveltyKind::kBox};
    const sim::ScenePair pair = sim::generateScenePair(config);
    Pipeline p(params);
    p.setReference(pair.current);
    const Result rr = p.detect(pair.reference);
    std::size_t labelled = 0;
    for (int l : rr.labels) labelled += l > 0;
    EXPECT_EQ(labelled, 0u) << "seed " << seed;
  }
}

TEST(HiddenSegments, MovedObjectReachingIntoTheShadowIsOneSegment) {
  // Viewpoint suite scene 15 (seed 1): a box moved (same pose) partly into the space the old
  // box hid from the reference: ~800 of its ~5,200 points lie where the reference never
  // looked. With the continuation rule they join the box's segment; without it (and without
  // object completion, which also takes them as part of a mostly new object) they are newly
  // visible. No revealed surface is labelled either way.
  const sim::ScenePair s = sim::generateScenePair(sim::viewpointSceneConfig(15, 1));
  const auto [ra, rb] = withAndWithout(s, &HiddenParams::continuations, 1.0);
  const Counts on = count(ra, s.current_labels, 0);
  const Counts off = count(rb, s.current_labels, 0);
  long revealed_novel = 0;
  for (std::size_t i = 0; i < ra.labels.size(); ++i)
    revealed_novel += s.current_newly_visible[i] && ra.labels[i] > 0;
  std::printf("viewpoint scene 15: object %ld points, found %ld with the rule, %ld without\n",
              on.object, on.found, off.found);
  ASSERT_GT(on.object, 4000);
  EXPECT_LT(off.found, on.object * 85 / 100);
  EXPECT_GE(on.found, on.object * 93 / 100);
  EXPECT_GE(on.found, off.found + 500);
  EXPECT_EQ(on.false_points, 0);
  EXPECT_EQ(revealed_novel, 0);
  EXPECT_EQ(ra.segments.size(), 1u);
  // Object completion alone takes them too.
  const auto [ca, cb] = withAndWithout(s, &HiddenParams::continuations);
  const Counts completed = count(cb, s.current_labels, 0);
  EXPECT_GE(completed.found, on.object * 93 / 100);
  EXPECT_EQ(completed.false_points, 0);
}

// Continuations grow breadth first from the segment and add at most max_growth times its own
// points: a 20-point segment at the start of a 200-point chain of hidden candidates (1 cm
// apart, link radius 1.5 cm) takes the 20 nearest with the default cap, all with a large
// one, none with 0.
TEST(HiddenSegments, ContinuationsGrowNearestFirstUpToTheCap) {
  Cloud cloud;
  for (int k = 0; k < 220; ++k) cloud.push_back(PointT(0.01f * k, 0.f, 0.f));
  Indices seed, hidden;
  for (int k = 0; k < 20; ++k) seed.push_back(k);
  for (int k = 20; k < 220; ++k) hidden.push_back(k);
  auto grow = [&](double cap) {
    std::vector<Indices> segments{seed};
    growIntoHidden(cloud, &segments, hidden, 0.015, cap);
    return segments[0];
  };
  const Indices capped = grow(1.0);
  ASSERT_EQ(capped.size(), 40u);
  for (int k = 0; k < 40; ++k) EXPECT_EQ(capped[k], k);  // the nearest links, in order
  EXPECT_EQ(grow(1000.0).size(), 220u);
  EXPECT_EQ(grow(0.0).size(), 20u);
}

// A continuation that is a revealed surface is none. A mapped wall (plane y = 0, 2 cm grid)
// has a hole the reference could not see (0.3 <= x <= 0.7, z <= 1); a novel door leaf stands
// on the hole's edge (plane x = 0.3, 0 < y <= 0.8). The hidden candidates filling the hole
// continue the wall's plane and not the leaf's: with the context they do not join the leaf,
// without it they do. The leaf's own hidden part (0.8 < y <= 1.2, away from the wall) joins
// either way. A leaf shut in the hole (its left half novel) takes its hidden right half,
// which continues the wall's plane and its own.
TEST(HiddenSegments, RevealedSurfacesAreNoContinuation) {
  const float s = 0.02f;
  Cloud reference, current;
  for (int i = -50; i <= 50; ++i)
    for (int k = 0; k <= 100; ++k) {
      const float x = s * i, z = s * k;
      if (x >= 0.3f - 1e-4f && x <= 0.7f + 1e-4f && z <= 1.0f + 1e-4f) continue;
      reference.push_back(PointT(x, 0.f, z));
    }
  Indices leaf, hole, far_leaf;
  for (int j = 1; j <= 60; ++j)
    for (int k = 0; k <= 50; ++k) {
      (j <= 40 ? leaf : far_leaf).push_back(static_cast<int>(current.size()));
      current.push_back(PointT(0.3f, s * j, s * k));
    }
  for (int i = 16; i <= 35; ++i)  // x = 0.32 .. 0.70: the hole beside the leaf
    for (int k = 0; k <= 50; ++k) {
      hole.push_back(static_cast<int>(current.size()));
      current.push_back(PointT(s * i, 0.f, s * k));
    }
  Indices hidden = far_leaf;
  hidden.insert(hidden.end(), hole.begin(), hole.end());
  std::sort(hidden.begin(), hidden.end());
  const MappedStructure mapped(reference, current, 0.03);
  const HiddenSegmentContext& ctx = mapped.ctx;
  const SegmentationParams params;
  EXPECT_TRUE(revealedSurface(ctx, hole, params));
  EXPECT_FALSE(revealedSurface(ctx, far_leaf, params));  // nothing mapped around it

  auto grow = [&](const HiddenSegmentContext* context, const Indices& candidates) {
    std::vector<Indices> segments{leaf};
    growIntoHidden(current, &segments, candidates, 1.5 * s, 1000.0, context, &params);
    return segments[0].size();
  };
  EXPECT_FALSE(continuesSegment(ctx, leaf, hole, params));
  EXPECT_TRUE(continuesSegment(ctx, leaf, far_leaf, params));
  EXPECT_EQ(grow(nullptr, hole), leaf.size() + hole.size());
  EXPECT_EQ(grow(&ctx, hole), leaf.size());
  EXPECT_EQ(grow(&ctx, far_leaf), leaf.size() + far_leaf.size());

  Indices shut_left, shut_right;  // the hole's points split at x = 0.5
  for (int i : hole) (current[i].x < 0.5f ? shut_left : shut_right).push_back(i);
  EXPECT_TRUE(revealedSurface(ctx, shut_right, params));
  EXPECT_TRUE(continuesSegment(ctx, shut_left, shut_right, params));
  std::vector<Indices> shut{shut_left};
  growIntoHidden(current, &shut, shut_right, 1.5 * s, 1000.0, &ctx, &params);
  EXPECT_EQ(shut[0].size(), hole.size());
}

// Suite scenes of seed 5 whose door leaf swung nearly shut, away from the space it filled: 17
// (86 -> 26 deg) and 20 (90 -> 19 deg). Continuations without the revealed-surface test carry
// the leaf's segment over the recess the old leaf hid (173 and 140 newly visible points, IoU
// 0.48); with it the leaf is found on its own (11 and 6 revealed points at the hinge join it). In
// scene 14 of seed 2 (89 -> 19 deg, 2,709 points) 717 points of the leaf the reference could not
// see continue the mapped wall and the leaf's own plane: they join it (without the second test the
// leaf's IoU is 0.49).
TEST(HiddenSegments, DoorLeafDoesNotGrowOverTheRecessItRevealed) {
  for (const auto& [index, seed] : {std::pair{17, 5}, std::pair{20, 5}, std::pair{14, 2}}) {
    const sim::ScenePair s = sim::generateScenePair(sim::suiteSceneConfig(index, seed));
    const int door = doorId(s);
    ASSERT_GT(door, 0);
    const Result r = sim_objects::detectLabels(s);
    long revealed = 0, leaf = 0, found = 0, best_segment = 0;
    std::map<int, long> on_leaf;
    for (std::size_t i = 0; i < r.labels.size(); ++i) {
      revealed += s.current_newly_visible[i] && r.labels[i] > 0;
      leaf += s.current_labels[i] == door;
      if (s.current_labels[i] == door && r.labels[i] > 0) ++on_leaf[r.labels[i]], ++found;
    }
    for (const auto& [id, n] : on_leaf) best_segment = std::max(best_segment, n);
    std::printf(
        "seed %d scene %d: leaf %ld points, %ld found (%ld in one segment), %ld newly "
        "visible labelled\n",
        seed, index, leaf, found, best_segment, revealed);
    // At most the few points at the hinge itself, within tau of the old leaf's edge, whose
    // surface turned with the leaf (turned_surfaces.h); the recess is not taken.
    EXPECT_LE(revealed, leaf / 15) << "seed " << seed << " scene " << index;
    EXPECT_GE(best_segment, leaf * 7 / 10) << "seed " << seed << " scene " << index;
  }
}

// Test 3 under a pose error. A mapped wall (plane x = 3 seen from the origin, 2 cm grid, a
// hole 4.0 < y < 4.8, z <= 1 where a box stood) is turned by 0.75 degrees about the sensor:
// about the hole it lies 5-6 cm beside the wall the sweep sees in the hole, beyond
// hidden_plane_factor * tau (3 cm) but parallel to it. The revealed patch still continues
// the map (through hidden_parallel_factor); with that factor 0 it does not. A door leaf
// hinged on the hole's edge at 50 degrees to the wall meets the turned wall along its hinge
// only, and none of that wall counts as parallel to it.
TEST(HiddenSegments, RevealedWallContinuesAMapSeenWithAPoseError) {
  const float s = 0.02f;
  const double yaw = 0.75 * M_PI / 180.0;
  const Eigen::Matrix3f turn =
      Eigen::AngleAxisf(static_cast<float>(yaw), Eigen::Vector3f::UnitZ()).toRotationMatrix();
  Cloud reference, current;
  for (int j = 0; j <= 200; ++j)
    for (int k = 0; k <= 100; ++k) {
      const float y = 2.5f + s * j, z = s * k;
      if (y > 4.0f + 1e-4f && y < 4.8f - 1e-4f && z <= 1.0f + 1e-4f) continue;
      PointT p;
      p.getVector3fMap() = turn * Eigen::Vector3f(3.f, y, z);
      reference.push_back(p);
    }
  Indices hole, leaf;
  for (int j = 1; j < 40; ++j)
    for (int k = 0; k <= 50; ++k) {
      hole.push_back(static_cast<int>(current.size()));
      current.push_back(PointT(3.f, 4.0f + s * j, s * k));
    }
  const Eigen::Vector3f along(std::sin(50.f * M_PI / 180.f), std::cos(50.f * M_PI / 180.f), 0.f);
  for (int j = 1; j <= 40; ++j)
    for (int k = 0; k <= 100; ++k) {
      leaf.push_back(static_cast<int>(current.size()));
      PointT p;
      p.getVector3fMap() = Eigen::Vector3f(3.f, 4.0f, s * k) + s * j * along;
      current.push_back(p);
    }
  const MappedStructure mapped(reference, current, 0.06);
  const HiddenSegmentContext& ctx = mapped.ctx;
  SegmentationParams params;
  const auto evidence = [&](const Indices& points) {
    const std::vector<Visibility> vis(points.size(), Visibility::kOccluded);
    return measureHiddenSegment(ctx, points, vis, params);
  };
  // The turned wall about the hole: none of it within 3 cm of the patch's plane.
  HiddenSegmentEvidence e = evidence(hole);
  std::printf("revealed patch: ring %d, on its plane %d (%d of them parallel beside it)\n", e.ring,
              e.ring_coplanar, e.ring_parallel);
  EXPECT_GT(e.ring, 500);
  EXPECT_GE(e.ring_coplanar, e.ring * 9 / 10);
  EXPECT_EQ(e.ring_parallel, e.ring_coplanar);
  EXPECT_TRUE(revealedSurface(ctx, hole, params));
  expectLeafMeetsTheWallAlongItsHingeOnly(ctx, leaf, params);
  // Without the parallel band the patch no longer continues the map.
  params.hidden.parallel_factor = 0.0;
  e = evidence(hole);
  EXPECT_EQ(e.ring_parallel, 0);
  EXPECT_LT(e.ring_coplanar, params.hidden.max_coplanar * e.ring);
  EXPECT_FALSE(revealedSurface(ctx, hole, params));
}

// The same far from a tilting laser, where its scan lines lie farther apart than the 2 tau
// of the local surface test: the wall (plane x = 3, turned by 0.75 degrees about the sensor
// at the origin) is sampled along horizontal lines 20 cm apart (tau = 6 cm), 2 cm along each,
// every point moved along its ray by up to 3 cm of range noise, which keeps each line in its
// scan plane through the sensor. The structure within 2 tau of a wall point is one line, a
// "plane" facing across the wall; the local surface is then taken within 4 tau, across
// three lines, and the turned wall about the revealed patch counts as parallel to it. The
// door leaf hinged on the hole's edge, sampled the same way, finds none of it parallel.
TEST(HiddenSegments, RevealedWallContinuesAMapSampledOnSparseScanLines) {
  const double yaw = 0.75 * M_PI / 180.0;
  const Eigen::Matrix3f turn =
      Eigen::AngleAxisf(static_cast<float>(yaw), Eigen::Vector3f::UnitZ()).toRotationMatrix();
  int serial = 0;
  // p moved along its ray from the origin by a deterministic noise in [-3, 3] cm.
  const auto noisy = [&serial](const Eigen::Vector3f& p) {
    const float n = 0.03f * std::sin(12.9898f * static_cast<float>(++serial));
    PointT q;
    q.getVector3fMap() = p * (1.f + n / p.norm());
    return q;
  };
  Cloud reference, current;
  const auto in_hole = [](float y, float z) { return y > 4.0f && y < 4.8f && z <= 1.0f + 1e-4f; };
  for (int line = 0; line <= 8; ++line)
    for (int j = 0; j <= 200; ++j) {
      const float y = 2.5f + 0.02f * j, z = 0.2f * line;
      if (!in_hole(y, z)) reference.push_back(noisy(turn * Eigen::Vector3f(3.f, y, z)));
    }
  Indices hole, leaf;
  for (int line = 0; line <= 5; ++line)
    for (int j = 1; j < 40; ++j) {
      hole.push_back(static_cast<int>(current.size()));
      current.push_back(noisy(Eigen::Vector3f(3.f, 4.0f + 0.02f * j, 0.2f * line)));
    }
  const Eigen::Vector3f along(std::sin(50.f * M_PI / 180.f), std::cos(50.f * M_PI / 180.f), 0.f);
  for (int line = 0; line <= 8; ++line)
    for (int j = 1; j <= 40; ++j) {
      leaf.push_back(static_cast<int>(current.size()));
      current.push_back(noisy(Eigen::Vector3f(3.f, 4.0f, 0.2f * line) + 0.02f * j * along));
    }
  const MappedStructure mapped(reference, current, 0.06);
  SegmentationParams params;
  const auto evidence = [&](const Indices& points) {
    const std::vector<Visibility> vis(points.size(), Visibility::kOccluded);
    return measureHiddenSegment(mapped.ctx, points, vis, params);
  };
  const HiddenSegmentEvidence e = evidence(hole);
  std::printf("revealed patch: ring %d, on its plane %d (%d of them parallel beside it)\n", e.ring,
              e.ring_coplanar, e.ring_parallel);
  EXPECT_GT(e.ring, 100);
  EXPECT_GE(e.ring_coplanar, e.ring * 3 / 4);
  EXPECT_GT(e.ring_parallel, e.ring / 2);
  EXPECT_TRUE(revealedSurface(mapped.ctx, hole, params));
  expectLeafMeetsTheWallAlongItsHingeOnly(mapped.ctx, leaf, params);
}

// Viewpoint suite scene 11 of seed 10: a box removed near the sensor reveals ~520 points of
// corridor wall behind it (940 newly visible points within 2 m of where it stood), the sweep
// registered with a localisation error of 0.4 degrees of yaw and pitch. Scene 17 of seed 11: a box
// removed 3.5 m away reveals ~400 points of office wall, 0.75 degrees of yaw off, where the tilt
// lines lie farther apart than 2 tau. The mapped wall about each revealed patch lies mostly beside
// its plane; as a parallel surface it still counts, and none of the revealed wall is novel. Without
// the parallel band the patch passes as a door leaf: a false segment of more than 1 % of the sweep.
// (A far wall the error shifts by more than tau gives a small false segment of its own either way.)
TEST(HiddenSegments, WallRevealedUnderALocalisationErrorIsNotNovel) {
  for (const auto& [index, seed] : {std::pair<int, std::uint64_t>{11, 10}, {17, 11}}) {
    const sim::ScenePair s = sim::generateScenePair(sim::viewpointSceneConfig(index, seed));
    ASSERT_EQ(sim::sceneGroup(s.config), "localisation_error");
    Params params;
    params.superquadric.enabled = false;
    params.alignment.enabled = false;  // the rule itself, on the sweep as registered
    Params without = params;
    without.segmentation.hidden.parallel_factor = 0.0;
    Pipeline a(params), b(without);
    a.setReference(s.reference);
    b.setReference(s.reference);
    const Result ra = a.detect(s.current), rb = b.detect(s.current);
    // The wall revealed behind the removed box: newly visible points within 2 m of where the
    // box stood (a far wall newly visible elsewhere is not it).
    Eigen::Vector3f box = Eigen::Vector3f::Zero();
    int box_points = 0;
    for (std::size_t i = 0; i < s.reference.size(); ++i)
      if (s.reference_labels[i] > 0) box += s.reference[i].getVector3fMap(), ++box_points;
    ASSERT_GT(box_points, 0);
    box /= static_cast<float>(box_points);
    long revealed = 0, revealed_on = 0, revealed_off = 0;
    for (std::size_t i = 0; i < ra.labels.size(); ++i) {
      const bool behind_box = s.current_newly_visible[i] &&
                              (s.current[i].getVector3fMap() - box).head<2>().norm() < 2.f;
      revealed += behind_box;
      revealed_on += behind_box && ra.labels[i] > 0;
      revealed_off += behind_box && rb.labels[i] > 0;
    }
    std::printf(
        "viewpoint scene %d, seed %d: %ld points revealed behind the box, %ld labelled with the "
        "parallel band, %ld without\n",
        index, static_cast<int>(seed), revealed, revealed_on, revealed_off);
    EXPECT_GT(revealed, 400) << "scene " << index << ", seed " << seed;
    EXPECT_EQ(revealed_on, 0) << "scene " << index << ", seed " << seed;
    EXPECT_GT(revealed_off, static_cast<long>(s.current.size() / 100))
        << "scene " << index << ", seed " << seed;
    const Counts on = count(ra, s.current_labels, 0);
    EXPECT_LT(on.false_points, static_cast<long>(s.current.size() / 100))
        << "scene " << index << ", seed " << seed;
  }
}

// Test 2 on a far door leaf, sampled by a tilting laser's lines 25 cm apart (tau = 5 cm):
// the leaf (0.8 x 1.8 m, plane y = 6 - x turned 45 degrees, range noise up to 2.5 cm across
// it) is linked across the gap above it to a row of eight returns of a wall 1 m behind its
// top, as at 5-7 m the link radius allows. The plane of all the points is tilted by the row
// and thicker than tau; the surface's plane is the leaf's, and the row is not on it.
TEST(HiddenSegments, StrayReturnsLinkedToALeafAreNotPartOfItsSurface) {
  const double tau = 0.05;
  const Eigen::Vector3f along = Eigen::Vector3f(1.f, -1.f, 0.f).normalized();
  const Eigen::Vector3f normal = Eigen::Vector3f(1.f, 1.f, 0.f).normalized();
  const Eigen::Vector3f hinge(3.f, 3.f, 0.f);
  Cloud current;
  Indices leaf, segment;
  int serial = 0;
  for (int line = 0; line <= 7; ++line)
    for (int j = 0; j <= 20; ++j) {
      const float n = 0.025f * std::sin(12.9898f * static_cast<float>(++serial));
      PointT p;
      p.getVector3fMap() =
          hinge + 0.04f * j * along + 0.25f * line * Eigen::Vector3f::UnitZ() + n * normal;
      leaf.push_back(static_cast<int>(current.size()));
      current.push_back(p);
    }
  for (int j = 0; j < 8; ++j) {
    PointT p;
    p.getVector3fMap() =
        hinge + 0.05f * j * along + 1.0f * normal + 2.3f * Eigen::Vector3f::UnitZ();
    current.push_back(p);
  }
  for (int i = 0; i < static_cast<int>(current.size()); ++i) segment.push_back(i);
  // The plane of all the points: thicker than tau.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const PointT& p : current) mean += p.getVector3fMap().cast<double>();
  mean /= static_cast<double>(current.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const PointT& p : current) {
    const Eigen::Vector3d d = p.getVector3fMap().cast<double>() - mean;
    cov += d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> all(cov / current.size());
  EXPECT_GT(std::sqrt(all.eigenvalues()(0)), tau);

  HiddenSegmentContext ctx;
  ctx.current = &current;
  ctx.tau = tau;
  const std::vector<Visibility> vis(segment.size(), Visibility::kOccluded);
  Indices surface;
  const HiddenSegmentEvidence e =
      measureHiddenSegment(ctx, segment, vis, SegmentationParams(), &surface);
  std::printf("leaf with strays: %d points, %d on the surface, thickness %.3f m\n", e.points,
              e.surface, e.thickness_m);
  EXPECT_EQ(surface, leaf);
  EXPECT_EQ(e.surface, static_cast<int>(leaf.size()));
  EXPECT_LT(e.thickness_m, 0.5 * tau);
  EXPECT_GT(e.width_m, tau);

  // Two surfaces at right angles, half the points each: no plane holds four fifths of them.
  Cloud corner;
  Indices both;
  for (int j = 0; j <= 20; ++j)
    for (int k = 0; k <= 20; ++k) {
      both.push_back(static_cast<int>(corner.size()));
      corner.push_back(PointT(3.f, 0.04f * j, 0.04f * k));
      both.push_back(static_cast<int>(corner.size()));
      corner.push_back(PointT(3.f + 0.04f * (j + 1), 0.f, 0.04f * k));
    }
  ctx.current = &corner;
  const std::vector<Visibility> corner_vis(both.size(), Visibility::kOccluded);
  const HiddenSegmentEvidence c = measureHiddenSegment(ctx, both, corner_vis, SegmentationParams());
  EXPECT_LT(c.surface, kMinSurfaceShare * c.points);
  EXPECT_FALSE(hiddenSegmentIsNovel(c, tau, SegmentationParams()));
}

// A door leaf 5.1-5.3 m away (suite seed 10, scene 24: 6 -> 61 deg, 73 points, 18 deg
// from face-on) swung into space the old leaf hid; eight returns of a wall 1 m behind its
// top and three beside it link to it across the gaps between tilt lines. The segment is
// the leaf's surface: found, and the returns behind it not labelled.
TEST(HiddenSegments, FarLeafLinkedToStrayReturnsIsNovel) {
  const sim::ScenePair s = sim::generateScenePair(sim::suiteSceneConfig(24, 10));
  const int door = doorId(s);
  ASSERT_GT(door, 0);
  const auto [ra, rb] = withAndWithout(s, &HiddenParams::segments);
  const Counts on = count(ra, s.current_labels, door);
  const Counts off = count(rb, s.current_labels, door);
  std::printf("door %ld points, found %ld with the rule, %ld without\n", on.object, on.found,
              off.found);
  EXPECT_EQ(off.found, 0);
  EXPECT_GE(on.found, on.object * 3 / 4);
  // The leaf's segment: no more than an eighth of it off the leaf (measured: 7 of 65 points,
  // returns of the recess wall just behind the leaf; the eight wall returns 1 m behind its top
  // are not on the leaf's surface).
  std::map<int, long> in_segment, on_leaf;
  for (std::size_t i = 0; i < s.current_labels.size(); ++i) {
    const int l = ra.labels[i];
    if (l <= 0) continue;
    ++in_segment[l];
    on_leaf[l] += s.current_labels[i] == door;
  }
  int leaf_segment = 0;
  for (const auto& [l, n] : on_leaf)
    if (n > on_leaf[leaf_segment]) leaf_segment = l;
  ASSERT_GT(leaf_segment, 0);
  std::printf("leaf segment: %ld points, %ld of them on the leaf\n", in_segment[leaf_segment],
              on_leaf[leaf_segment]);
  EXPECT_LE(in_segment[leaf_segment] - on_leaf[leaf_segment], in_segment[leaf_segment] / 8);
}
