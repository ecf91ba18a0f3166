// Linking novel points into segments (segmentation/novelty_segmentation.h) with known
// answers: the link radius follows the sweep's own sampling where novel points are
// scattered more sparsely than the sweep samples.
#include <gtest/gtest.h>

#include <cmath>

#include "novelty_detection/params.h"
#include "novelty_detection/segmentation/novelty_segmentation.h"
#include "novelty_detection/segmentation/object_completion.h"

using namespace novelty_detection;

namespace {

/// A 4 x 4 m floor sampled every 5 cm; index of the sample at (i, j) is i * 80 + j.
Cloud grid() {
  Cloud c;
  for (int i = 0; i < 80; ++i)
    for (int j = 0; j < 80; ++j) c.push_back(PointT(0.05f * i, 0.05f * j, 0.0f));
  c.width = c.size(), c.height = 1;
  return c;
}

}  // namespace

TEST(SweepSpacing, IsTheSweepsOwnSampling) {
  const Cloud c = grid();
  Indices all(c.size()), some;
  for (std::size_t i = 0; i < c.size(); ++i) all[i] = static_cast<int>(i);
  for (int i = 10; i < 70; i += 8) some.push_back(i * 80 + 40);
  EXPECT_NEAR(sweepSpacing(c, all, some), 0.05, 1e-6);
  EXPECT_TRUE(std::isinf(sweepSpacing(c, all, {})));
}

// A dense novel patch (10 x 6 samples) among 64 novel samples scattered 0.4 m apart over the
// same floor (a far wall's stray differences): their mutual spacing (about 0.4 m) would link
// all of them into the patch; the sweep's spacing (5 cm) keeps the patch alone and leaves
// the stray samples as pieces too small to be segments.
TEST(SegmentNovelPoints, ScatteredPointsDoNotJoinADenseObject) {
  const Cloud c = grid();
  Indices all(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) all[i] = static_cast<int>(i);
  Indices novel, patch;
  std::vector<int> owner;
  for (int i = 0; i < 80; ++i) {
    for (int j = 0; j < 80; ++j) {
      const bool in_patch = i >= 35 && i < 45 && j >= 37 && j < 43;
      const bool stray = i % 8 == 4 && j % 8 == 4 && !(i >= 30 && i < 50 && j >= 32 && j < 48);
      if (!in_patch && !stray) continue;
      novel.push_back(i * 80 + j);
      owner.push_back(in_patch ? 0 : 1);
      if (in_patch) patch.push_back(i * 80 + j);
    }
  }
  ASSERT_EQ(patch.size(), 60u);
  ASSERT_GT(novel.size() - patch.size(), patch.size());  // the stray samples dominate
  SegmentationParams p;
  double radius = 0.0;
  SweepContext sweep;
  sweep.kept = &all;
  const std::vector<Indices> own = segmentNovelPoints(c, novel, owner, 2, p, &radius, sweep);
  EXPECT_NEAR(radius, p.link_factor * 0.05, 1e-6);
  ASSERT_EQ(own.size(), 1u);
  EXPECT_EQ(own[0], patch);
  // Without the sweep's spacing the stray samples link up and swallow the patch.
  const std::vector<Indices> mutual = segmentNovelPoints(c, novel, owner, 2, p, &radius);
  ASSERT_FALSE(mutual.empty());
  EXPECT_GT(mutual[0].size(), patch.size() + 10);
}

namespace {

/// Two novel pieces of different Gaussians one above the other, 5 cm samples: a lower one
/// (x 3.0-3.2, y -0.2-0.2, z 0-0.5) and an upper one (same footprint, z 0.9-1.2), 0.4 m
/// apart (within merge_gap_factor link radii). With `wall`, the sweep also holds a wall at
/// x = 5 (y -1-1, z -0.5-2, 5 cm samples) without the returns the pieces hide from the
/// sensor at (0, 0, 0.7).
struct StackedScene {
  Cloud cloud;
  Indices all, novel;
  std::vector<int> owner;
  /// Every point kept, the sensor's origin known.
  SweepContext sweep() const {
    SweepContext c;
    c.kept = &all;
    c.origin_known = true;
    c.origin = cloud.sensor_origin_.head<3>();
    return c;
  }
  /// A point; novel, of Gaussian `by`, when by >= 0.
  void add(float x, float y, float z, int by) {
    if (by >= 0) novel.push_back(static_cast<int>(cloud.size())), owner.push_back(by);
    cloud.push_back(PointT(x, y, z));
  }
  /// Every point is kept; the sensor at `origin`.
  void finish(const Eigen::Vector3f& origin) {
    cloud.width = cloud.size(), cloud.height = 1;
    all.resize(cloud.size());
    for (std::size_t i = 0; i < cloud.size(); ++i) all[i] = static_cast<int>(i);
    cloud.sensor_origin_.head<3>() = origin;
  }
};

/// Adds a wall of 5 cm samples at x = 5 (y -1..1, z from z0, `rows` + 1 rows) seen from
/// `origin`, without the returns whose beam crosses x = 3.0 or x = 3.2 where `blocked` says
/// something nearer hides them.
template <class Blocked>
void addWallBehind(StackedScene* s, const Eigen::Vector3f& origin, float z0, int rows,
                   Blocked blocked) {
  for (int j = 0; j <= 40; ++j)
    for (int k = 0; k <= rows; ++k) {
      const Eigen::Vector3f p(5.f, -1.f + 0.05f * j, z0 + 0.05f * k);
      bool hidden = false;
      for (float x : {3.0f, 3.2f})
        hidden |= blocked(origin + (p - origin) * ((x - origin.x()) / (p.x() - origin.x())));
      if (!hidden) s->add(p.x(), p.y(), p.z(), -1);
    }
}

StackedScene stackedPieces(bool wall) {
  StackedScene s;
  const Eigen::Vector3f origin(0.f, 0.f, 0.7f);
  for (int i = 0; i <= 4; ++i)
    for (int j = 0; j <= 8; ++j) {
      for (int k = 0; k <= 10; ++k) s.add(3.0f + 0.05f * i, -0.2f + 0.05f * j, 0.05f * k, 0);
      for (int k = 0; k <= 6; ++k) s.add(3.0f + 0.05f * i, -0.2f + 0.05f * j, 0.9f + 0.05f * k, 1);
    }
  if (wall) {
    // Where a beam crosses x = 3-3.2, it must miss both pieces.
    addWallBehind(&s, origin, -0.5f, 50, [](const Eigen::Vector3f& q) {
      return std::abs(q.y()) <= 0.2f &&
             ((q.z() >= 0.f && q.z() <= 0.5f) || (q.z() >= 0.9f && q.z() <= 1.2f));
    });
  }
  s.finish(origin);
  return s;
}

}  // namespace

// Stacked pieces merge when nothing says the gap between them is empty (one object cut by a
// gap between tilt lines), and stay apart when the sweep's beams crossed that gap to a wall
// behind (a person below a stray difference higher up).
TEST(SegmentNovelPoints, StackedPiecesStayApartWhenTheSweepSawThroughTheGap) {
  SegmentationParams p;
  const std::size_t lower = 5 * 9 * 11, upper = 5 * 9 * 7;
  for (const bool wall : {false, true}) {
    const StackedScene s = stackedPieces(wall);
    SweepContext sweep = s.sweep();
    double radius = 0.0;
    const std::vector<Indices> seen =
        segmentNovelPoints(s.cloud, s.novel, s.owner, 2, p, &radius, sweep);
    ASSERT_LT(p.merge_gap_factor * radius, 0.6);  // the gap itself is within merge range
    ASSERT_GT(p.merge_gap_factor * radius, 0.4);
    if (wall) {
      ASSERT_EQ(seen.size(), 2u);
      EXPECT_EQ(seen[0].size(), lower);
      EXPECT_EQ(seen[1].size(), upper);
      // Without the sensor origin nothing is known of the gap: merged.
      sweep.origin_known = false;
      const std::vector<Indices> blind =
          segmentNovelPoints(s.cloud, s.novel, s.owner, 2, p, &radius, sweep);
      ASSERT_EQ(blind.size(), 1u);
      EXPECT_EQ(blind[0].size(), lower + upper);
    } else {
      ASSERT_EQ(seen.size(), 1u);
      EXPECT_EQ(seen[0].size(), lower + upper);
    }
  }
}

namespace {

/// Two novel pieces of ONE Gaussian side by side, seen from (0, 0, 0.7): boxes of 5 cm
/// samples over x 3.0-3.2, z 0-0.5, one at y -0.45..-0.1, the other at y 0.1..0.45, a 0.2 m
/// gap between their footprints (within merge_floor_gap_factor link radii). `beyond`: a wall
/// at x = 5 (y -1..1, z 0..1.5) behind them, without the returns they hide, so that beams pass
/// through the gap to it. `inside`: returns of a surface lying in the gap itself (x 3.1,
/// y -0.05..0.05, z 0-0.5; not novel), beams that end in the gap rather than pass it.
StackedScene sideBySidePieces(bool beyond, bool inside) {
  StackedScene s;
  const Eigen::Vector3f origin(0.f, 0.f, 0.7f);
  for (int i = 0; i <= 4; ++i)
    for (int j = 0; j <= 7; ++j)
      for (int k = 0; k <= 10; ++k) {
        s.add(3.0f + 0.05f * i, -0.45f + 0.05f * j, 0.05f * k, 0);
        s.add(3.0f + 0.05f * i, 0.1f + 0.05f * j, 0.05f * k, 0);
      }
  if (inside)
    for (int j = 0; j <= 2; ++j)
      for (int k = 0; k <= 10; ++k) s.add(3.1f, -0.05f + 0.05f * j, 0.05f * k, -1);
  if (beyond) {
    // Where a beam crosses x = 3-3.2 it must miss both pieces (and the inner surface).
    addWallBehind(&s, origin, 0.f, 30, [inside](const Eigen::Vector3f& q) {
      const float ay = std::abs(q.y());
      return q.z() >= 0.f && q.z() <= 0.5f &&
             ((ay >= 0.1f && ay <= 0.45f) || (inside && ay <= 0.05f));
    });
  }
  s.finish(origin);
  return s;
}

}  // namespace

// Pieces side by side that one Gaussian owns merge as one object seen through gaps, unless
// the sweep's beams passed between them to something beyond (two objects a hand apart):
// returns that end inside the gap do not count, pieces too small to be segments are not two
// objects, and without the sensor origin nothing is known of the gap.
TEST(SegmentNovelPoints, SideBySidePiecesStayApartWhenTheSweepSawPastTheGap) {
  SegmentationParams p;
  const std::size_t piece = 5 * 8 * 11;
  for (const bool beyond : {false, true}) {
    for (const bool inside : {false, true}) {
      const StackedScene s = sideBySidePieces(beyond, inside);
      SweepContext sweep = s.sweep();
      double radius = 0.0;
      const std::vector<Indices> seen =
          segmentNovelPoints(s.cloud, s.novel, s.owner, 1, p, &radius, sweep);
      ASSERT_GT(p.merge_floor_gap_factor * radius, 0.2);  // the gap is within merge range
      ASSERT_LT(radius, 0.2);                             // and the pieces are not linked
      if (beyond) {
        ASSERT_EQ(seen.size(), 2u) << "inside " << inside;
        EXPECT_EQ(seen[0].size(), piece);
        EXPECT_EQ(seen[1].size(), piece);
        // Pieces too small to be segments on their own are not two objects: merged.
        SegmentationParams large = p;
        large.min_segment_points = static_cast<int>(piece) + 1;
        const std::vector<Indices> small =
            segmentNovelPoints(s.cloud, s.novel, s.owner, 1, large, &radius, sweep);
        ASSERT_EQ(small.size(), 1u);
        EXPECT_EQ(small[0].size(), 2 * piece);
        sweep.origin_known = false;
        const std::vector<Indices> blind =
            segmentNovelPoints(s.cloud, s.novel, s.owner, 1, p, &radius, sweep);
        ASSERT_EQ(blind.size(), 1u);
        EXPECT_EQ(blind[0].size(), 2 * piece);
      } else {
        ASSERT_EQ(seen.size(), 1u) << "inside " << inside;
        EXPECT_EQ(seen[0].size(), 2 * piece);
      }
    }
  }
}

namespace {

/// Points of a 5 cm grid on the plane x = x0 over y in [y0, y1], z in [z0, z1].
void addWall(Cloud* c, float x0, float y0, float y1, float z0, float z1) {
  for (float y = y0; y <= y1 + 1e-4f; y += 0.05f)
    for (float z = z0; z <= z1 + 1e-4f; z += 0.05f) c->push_back(PointT(x0, y, z));
}

}  // namespace

// A new object of which most points were found novel takes its other points (the part on a
// surface the map had); an unchanged object touched by a small new one stays as it is; points
// the caller refuses are passed through, not taken.
TEST(CompleteObjects, MostlyNovelObjectsAreTakenWhole) {
  Cloud c;
  addWall(&c, 1.f, 0.f, 0.5f, 0.f, 0.45f);  // object A: 11 x 10 samples, indices 0..109
  const int a_end = static_cast<int>(c.size());
  addWall(&c, 3.f, 0.f, 1.f, 0.f, 0.95f);  // object B (unchanged): 21 x 20 samples
  const int b_end = static_cast<int>(c.size());
  addWall(&c, 3.f, 1.05f, 1.2f, 0.f, 0.2f);  // a small new object C touching B: 4 x 5
  c.width = c.size(), c.height = 1;
  Indices kept(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) kept[i] = static_cast<int>(i);
  // A: its upper 7 rows of 10 novel (70 %); C: all of it novel (20 points against B's 420).
  Indices a_novel, c_all;
  for (int i = 0; i < a_end; ++i)
    if (i % 10 >= 3) a_novel.push_back(i);
  for (int i = b_end; i < static_cast<int>(c.size()); ++i) c_all.push_back(i);
  const double radius = 0.06;
  auto all = [](int) { return true; };
  std::vector<Indices> segs{a_novel, c_all};
  completeObjects(c, kept, radius, 0.6, all, &segs);
  ASSERT_EQ(segs.size(), 2u);
  EXPECT_EQ(segs[0].size(), static_cast<std::size_t>(a_end));  // A whole
  EXPECT_EQ(segs[1], c_all);                                   // B not taken
  // Below the share nothing changes.
  std::vector<Indices> strict{a_novel, c_all};
  completeObjects(c, kept, radius, 0.8, all, &strict);
  EXPECT_EQ(strict[0], a_novel);
  // A refused row (z = 0.1: index % 10 == 2) is passed: the rows below it still join.
  std::vector<Indices> gated{a_novel, c_all};
  completeObjects(
      c, kept, radius, 0.6, [](int i) { return i % 10 != 2; }, &gated);
  EXPECT_EQ(gated[0].size(), static_cast<std::size_t>(a_end) - 11);
  for (int i : gated[0]) EXPECT_NE(i % 10, 2);
}
