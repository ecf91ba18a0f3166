// Linking novel points into segments (segmentation/novelty_segmentation.h) with known
// answers: the link radius follows the sweep's own sampling where novel points are
// scattered more sparsely than the sweep samples.
#include <gtest/gtest.h>

#include <cmath>

#include "novelty_detection/params.h"
#include "novelty_detection/segmentation/novelty_segmentation.h"

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
  const std::vector<Indices> own =
      segmentNovelPoints(c, novel, owner, 2, p, &radius, sweepSpacing(c, all, novel));
  EXPECT_NEAR(radius, p.link_factor * 0.05, 1e-6);
  ASSERT_EQ(own.size(), 1u);
  EXPECT_EQ(own[0], patch);
  // Without the sweep's spacing the stray samples link up and swallow the patch.
  const std::vector<Indices> mutual = segmentNovelPoints(c, novel, owner, 2, p, &radius);
  ASSERT_FALSE(mutual.empty());
  EXPECT_GT(mutual[0].size(), patch.size() + 10);
}
