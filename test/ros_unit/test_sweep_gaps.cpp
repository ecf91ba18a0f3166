// Sweeps lost upstream, counted from the headers of those that arrive.
#include <gtest/gtest.h>

#include <cstdint>

#include "novelty_detection/ros/sweep_gaps.h"

using novelty_detection::SweepGaps;

TEST(SweepGaps, SequenceJumpsCountTheMissingSweeps) {
  SweepGaps g;
  EXPECT_EQ(g.observe(10, 100.0), 0u);  // the first
  EXPECT_EQ(g.observe(11, 100.1), 0u);
  EXPECT_EQ(g.observe(14, 100.4), 2u);  // 12 and 13 lost
  EXPECT_EQ(g.observe(15, 100.5), 0u);
  EXPECT_EQ(g.observe(25, 101.5), 9u);
  EXPECT_EQ(g.missing(), 11u);
}

TEST(SweepGaps, ConstantSequenceFallsBackToTheStamps) {
  // seq left at 0 by the driver; a sweep every 0.5 s with a little jitter.
  SweepGaps g;
  double t = 50.0;
  for (int i = 0; i < 6; ++i, t += (i % 2 ? 0.49 : 0.51)) EXPECT_EQ(g.observe(0, t), 0u);
  EXPECT_EQ(g.observe(0, t + 1.5), 3u);  // 1.5 s + the 0.5 s step: four periods, three lost
  t += 1.5;
  EXPECT_EQ(g.observe(0, t + 0.5), 0u);
  EXPECT_EQ(g.observe(0, t + 0.9), 0u);  // early is not lost
  EXPECT_EQ(g.missing(), 3u);
}

TEST(SweepGaps, FewIntervalsSeenCountNothingFromStamps) {
  SweepGaps g;
  EXPECT_EQ(g.observe(0, 1.0), 0u);
  EXPECT_EQ(g.observe(0, 1.1), 0u);
  EXPECT_EQ(g.observe(0, 5.0), 0u);  // no period known yet
  EXPECT_EQ(g.missing(), 0u);
}

TEST(SweepGaps, AnIrregularSourceIsNotCountedFromStamps) {
  // Sweeps on demand: 0.1 s, 3 s, 0.2 s, 1 s, ... apart.
  SweepGaps g;
  double t = 0.0;
  for (double dt : {0.1, 3.0, 0.2, 1.0, 0.1, 2.5, 0.3, 6.0}) EXPECT_EQ(g.observe(0, t += dt), 0u);
  EXPECT_EQ(g.missing(), 0u);
}

TEST(SweepGaps, ReplaysAndRestartsStartOver) {
  SweepGaps g;
  EXPECT_EQ(g.observe(100, 10.0), 0u);
  EXPECT_EQ(g.observe(101, 10.1), 0u);
  EXPECT_EQ(g.observe(1, 0.5), 0u);         // the bag again: seq and time went back
  EXPECT_EQ(g.observe(3, 0.7), 1u);         // counting resumes from there
  EXPECT_EQ(g.observe(4000000, 0.8), 0u);   // a new source's numbering is not a gap
  EXPECT_EQ(g.observe(4000001, 0.8), 0u);   // same stamp: not an interval
  EXPECT_EQ(g.observe(UINT32_MAX, 0.9), 0u);
  EXPECT_EQ(g.observe(0, 1.0), 0u);         // wrap-around
  EXPECT_EQ(g.missing(), 1u);
}
