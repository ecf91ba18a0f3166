// The segment-level rule for candidates hidden from the reference (hidden_segments.h), with
// known answers: the rule's clauses on measured evidence; door leaves swung into space the
// old leaf hid (simulated suite scenes, seed 1) are novel with the rule and missed without
// it; the wall revealed behind a moved box in a corner and the surfaces revealed behind a
// removed box stay not novel; a moved box reaching into the old box's shadow is found whole.
#include <gtest/gtest.h>

#include <cstdio>
#include <utility>

#include "novelty_detection/pipeline.h"
#include "novelty_detection/segmentation/hidden_segments.h"
#include "novelty_detection/sim/scene.h"

using namespace novelty_detection;

namespace {

HiddenSegmentEvidence doorLike(double tau) {
  HiddenSegmentEvidence e;
  e.points = 200;
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

}  // namespace

TEST(HiddenSegments, RuleClauses) {
  const double tau = 0.08;
  SegmentationParams p;
  EXPECT_TRUE(hiddenSegmentIsNovel(doorLike(tau), tau, p));
  HiddenSegmentEvidence e = doorLike(tau);
  e.occluded = 90;  // mostly out of the reference's view, not behind something it saw
  EXPECT_FALSE(hiddenSegmentIsNovel(e, tau, p));
  e = doorLike(tau);
  e.width_m = 0.9 * tau;  // a line: no plane
  EXPECT_FALSE(hiddenSegmentIsNovel(e, tau, p));
  e = doorLike(tau);
  e.thickness_m = 1.1 * tau;  // not a surface patch
  EXPECT_FALSE(hiddenSegmentIsNovel(e, tau, p));
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
  Params params;
  params.superquadric.enabled = false;
  Pipeline pipeline(params);
  pipeline.setReference(s.reference);
  const Result r = pipeline.detect(s.current);
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
