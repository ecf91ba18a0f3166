// Tracks of changes over a stream of sweeps: known sequences of segments with exact answers.
#include <gtest/gtest.h>

#include <random>

#include "novelty_detection/tracking/change_tracker.h"

using namespace novelty_detection;

namespace {

Segment segmentAt(const Eigen::Vector3d& centre, const Eigen::Vector3d& half) {
  Segment s;
  s.id = 1;
  s.centroid = centre;
  s.bbox_min = centre - half;
  s.bbox_max = centre + half;
  return s;
}

const Eigen::AlignedBox3d kRoom(Eigen::Vector3d(-10, -10, -1), Eigen::Vector3d(10, 10, 3));
const Eigen::Vector3d kBoxHalf(0.2, 0.2, 0.25), kPersonHalf(0.25, 0.2, 0.9);

}  // namespace

TEST(BoxOverlap, KnownVolumes) {
  const Eigen::Vector3d o = Eigen::Vector3d::Zero(), one = Eigen::Vector3d::Ones();
  EXPECT_DOUBLE_EQ(boxOverlap(o, one, o, one), 1.0);
  // Two unit cubes sharing half their volume: 0.5 / 1.5.
  EXPECT_NEAR(boxOverlap(o, one, Eigen::Vector3d(0.5, 0, 0), Eigen::Vector3d(1.5, 1, 1)), 1.0 / 3.0,
              1e-12);
  EXPECT_EQ(boxOverlap(o, one, Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(3, 1, 1)), 0.0);
  EXPECT_EQ(boxOverlap(one, o, o, one), 0.0);  // an empty box
}

TEST(ChangeTracker, AStayingBoxKeepsItsIdAndIsConfirmedOnItsSecondSweep) {
  TrackingParams p;  // confirm after 2
  ChangeTracker tracker(p);
  std::mt19937 rng(4);
  std::normal_distribution<double> jitter(0.0, 0.03);
  std::uint32_t id = 0;
  for (int sweep = 0; sweep < 6; ++sweep) {
    const Eigen::Vector3d c(2.0 + jitter(rng), 1.0 + jitter(rng), 0.25);
    const auto ids = tracker.update({segmentAt(c, kBoxHalf)}, sweep * 1.5, kRoom);
    ASSERT_EQ(ids.size(), 1u);
    if (sweep == 0) id = ids[0];
    EXPECT_EQ(ids[0], id) << "sweep " << sweep;
    const ChangeTrack* t = tracker.track(id);
    ASSERT_NE(t, nullptr);
    EXPECT_EQ(t->times_seen, sweep + 1);
    EXPECT_EQ(t->confirmed, sweep >= 1);
    EXPECT_DOUBLE_EQ(t->first_seen, 0.0);
    EXPECT_DOUBLE_EQ(t->last_seen, sweep * 1.5);
  }
  EXPECT_EQ(tracker.tracks().size(), 1u);
}

TEST(ChangeTracker, AWalkingPersonIsNeverConfirmedAndIsDroppedOnceGone) {
  ChangeTracker tracker{TrackingParams()};
  const Eigen::Vector3d box(5.0, -1.0, 0.25);
  std::vector<std::uint32_t> person_ids;
  for (int sweep = 0; sweep < 6; ++sweep) {
    // 1 m per sweep along the corridor: a walking pace at a tilting laser's sweep rate.
    const Eigen::Vector3d person(-4.0 + sweep, 0.5, 0.9);
    const auto ids =
        tracker.update({segmentAt(person, kPersonHalf), segmentAt(box, kBoxHalf)}, sweep, kRoom);
    person_ids.push_back(ids[0]);
    EXPECT_FALSE(tracker.track(ids[0])->confirmed) << "sweep " << sweep;
    EXPECT_EQ(tracker.track(ids[1])->confirmed, sweep >= 1);
  }
  for (std::size_t i = 1; i < person_ids.size(); ++i) EXPECT_NE(person_ids[i], person_ids[i - 1]);
  // Each place the person left was covered and empty for 2 sweeps: those tracks are gone.
  for (int sweep = 6; sweep < 8; ++sweep) tracker.update({segmentAt(box, kBoxHalf)}, sweep, kRoom);
  ASSERT_EQ(tracker.tracks().size(), 1u);
  EXPECT_TRUE(tracker.tracks()[0].confirmed);
  EXPECT_EQ(tracker.transientDropped(), 6u);
}

TEST(ChangeTracker, APlaceOutOfViewKeepsItsTrackAndAGoneChangeIsForgotten) {
  TrackingParams p;
  p.forget_sweeps = 3;
  ChangeTracker tracker(p);
  const Eigen::Vector3d box(8.0, 0.0, 0.25);
  const auto ids = tracker.update({segmentAt(box, kBoxHalf)}, 0.0, kRoom);
  tracker.update({segmentAt(box, kBoxHalf)}, 1.0, kRoom);
  // The robot turned away: sweeps that do not cover x = 8 leave the track alone.
  const Eigen::AlignedBox3d elsewhere(Eigen::Vector3d(-10, -10, -1), Eigen::Vector3d(0, 10, 3));
  for (int s = 2; s < 10; ++s) tracker.update({}, s, elsewhere);
  ASSERT_NE(tracker.track(ids[0]), nullptr);
  EXPECT_EQ(tracker.track(ids[0])->missed, 0);
  // Back, and the box is gone: dropped on the third covering sweep without it.
  tracker.update({}, 10, kRoom);
  tracker.update({}, 11, kRoom);
  ASSERT_NE(tracker.track(ids[0]), nullptr);
  EXPECT_EQ(tracker.track(ids[0])->missed, 2);
  tracker.update({}, 12, kRoom);
  EXPECT_EQ(tracker.track(ids[0]), nullptr);
  EXPECT_EQ(tracker.dropped(), 1u);
  EXPECT_EQ(tracker.transientDropped(), 0u);  // it had been confirmed
}

TEST(ChangeTracker, AnObjectSeenFromAnotherSideMatchesByItsBox) {
  TrackingParams p;
  p.gate_m = 0.1;
  ChangeTracker tracker(p);
  // A 2 m long bench: first its left 1.6 m, then its right 1.6 m (centroids 0.4 m apart,
  // beyond the gate; boxes overlap 1.2 / 2.0 = 0.6).
  const Eigen::Vector3d half(0.8, 0.2, 0.25);
  const auto a = tracker.update({segmentAt({-0.2, 0, 0.25}, half)}, 0, kRoom);
  const auto b = tracker.update({segmentAt({0.2, 0, 0.25}, half)}, 1, kRoom);
  EXPECT_EQ(a[0], b[0]);
  p.min_overlap = 0.7;
  tracker.setParams(p);
  const auto c = tracker.update({segmentAt({-0.2, 0, 0.25}, half)}, 2, kRoom);
  EXPECT_NE(c[0], b[0]);
}

TEST(ChangeTracker, EachTrackTakesOneSegmentNearestFirst) {
  ChangeTracker tracker{TrackingParams()};
  const auto first = tracker.update({segmentAt({0, 0, 0.25}, kBoxHalf)}, 0, kRoom);
  // Two segments within the gate of the one track: the nearer continues it.
  const auto next = tracker.update(
      {segmentAt({0.25, 0, 0.25}, kBoxHalf), segmentAt({0.05, 0, 0.25}, kBoxHalf)}, 1, kRoom);
  EXPECT_NE(next[0], first[0]);
  EXPECT_EQ(next[1], first[0]);
  EXPECT_EQ(tracker.tracks().size(), 2u);
}

TEST(ChangeTracker, ConfirmationAtOnceResetAndBoundedMemory) {
  TrackingParams p;
  p.confirm_sweeps = 1;
  ChangeTracker tracker(p);
  const auto ids = tracker.update({segmentAt({1, 1, 0.25}, kBoxHalf)}, 0, kRoom);
  EXPECT_TRUE(tracker.track(ids[0])->confirmed);
  tracker.reset();
  EXPECT_TRUE(tracker.tracks().empty());
  // Many changes, each once, out of view afterwards: at most kMaxTracks stay.
  const Eigen::AlignedBox3d nowhere(Eigen::Vector3d(100, 100, 100), Eigen::Vector3d(101, 101, 101));
  std::vector<Segment> many;
  for (int i = 0; i < 1200; ++i) many.push_back(segmentAt({i * 1.0, 0, 0}, kBoxHalf));
  tracker.update(many, 1, nowhere);
  EXPECT_EQ(tracker.tracks().size(), ChangeTracker::kMaxTracks);
  EXPECT_EQ(tracker.dropped(), 200u);
  p.confirm_sweeps = 0;
  EXPECT_THROW(tracker.setParams(p), std::invalid_argument);
}
