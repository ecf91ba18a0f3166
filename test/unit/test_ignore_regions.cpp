// Ignore regions: parsing, the box test, and detection on simulated scenes with exact ground
// truth (a region over one of two new objects, a region over a removed one).
#include <gtest/gtest.h>

#include <cmath>

#include "novelty_detection/pipeline.h"
#include "novelty_detection/preprocess/ignore_regions.h"
#include "novelty_detection/sim/scene.h"

using namespace novelty_detection;

namespace {

/// The ground-truth points of object `id` as an axis-aligned region grown by `margin_m`.
std::string regionAround(const Cloud& cloud, const std::vector<int>& labels, int id,
                         double margin_m) {
  Eigen::AlignedBox3d box;
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (labels[i] == id) box.extend(cloud[i].getVector3fMap().cast<double>());
  IgnoreRegion r;
  r.centre = box.center();
  r.half_extent = 0.5 * box.sizes() + Eigen::Vector3d::Constant(margin_m);
  return formatIgnoreRegions({r});
}

std::size_t labelledOn(const Result& r, const std::vector<int>& truth, int id) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < truth.size(); ++i) n += truth[i] == id && r.labels[i] > 0;
  return n;
}

}  // namespace

TEST(IgnoreRegions, ParsesBoxesAndRefusesBadOnes) {
  EXPECT_TRUE(parseIgnoreRegions("").empty());
  EXPECT_TRUE(parseIgnoreRegions(" ; ").empty());
  const auto r = parseIgnoreRegions("0 0 0 2 1 3; -1 -1 0 1 1 1 90");
  ASSERT_EQ(r.size(), 2u);
  EXPECT_TRUE(r[0].centre.isApprox(Eigen::Vector3d(1, 0.5, 1.5)));
  EXPECT_TRUE(r[0].half_extent.isApprox(Eigen::Vector3d(1, 0.5, 1.5)));
  EXPECT_DOUBLE_EQ(r[0].yaw_rad, 0.0);
  EXPECT_NEAR(r[1].yaw_rad, M_PI / 2, 1e-12);
  // The text form parses back to the same boxes.
  const auto again = parseIgnoreRegions(formatIgnoreRegions(r));
  ASSERT_EQ(again.size(), 2u);
  EXPECT_TRUE(again[1].centre.isApprox(r[1].centre));
  EXPECT_NEAR(again[1].yaw_rad, r[1].yaw_rad, 1e-12);
  for (const char* bad : {"0 0 0 1 1", "0 0 0 1 1 1 0 0", "1 0 0 0 1 1", "0 0 0 1 x 1",
                          "0 0 0 1 1 nan", "0 0 0 1 1 1e9", "0 0 0 1 1 1; 2"}) {
    try {
      parseIgnoreRegions(bad);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("preprocess/ignore_regions"), std::string::npos);
    }
  }
  Params p;
  p.preprocess.ignore_regions = "0 0 0 1 1";
  EXPECT_THROW(p.validate(), std::invalid_argument);
}

TEST(IgnoreRegions, ATurnedBoxContainsWhatItsCornersSpan) {
  // A 2 m x 0.2 m box turned by 45 deg: its long axis runs along x = y.
  const auto r = parseIgnoreRegions("-1 -0.1 0 1 0.1 1 45");
  ASSERT_EQ(r.size(), 1u);
  EXPECT_TRUE(r[0].contains({0.6, 0.6, 0.5}));
  EXPECT_TRUE(r[0].contains({-0.6, -0.6, 0.5}));
  EXPECT_FALSE(r[0].contains({0.6, -0.6, 0.5}));
  EXPECT_FALSE(r[0].contains({0.9, 0.0, 0.5}));  // inside the unturned box, not the turned
  EXPECT_FALSE(r[0].contains({0.6, 0.6, 1.2}));
  Cloud c;
  c.push_back(PointT(0.5f, 0.5f, 0.5f));
  c.push_back(PointT(0.5f, -0.5f, 0.5f));
  c.push_back(PointT(std::nanf(""), 0.f, 0.f));
  EXPECT_EQ(maskIgnoreRegions(r, c), 1u);
  EXPECT_TRUE(std::isnan(c[0].x));
  EXPECT_FLOAT_EQ(c[1].x, 0.5f);
  EXPECT_FALSE(c.is_dense);
}

// Two new objects; a region over the first: its points are ignored (exact count), never
// labelled nor newly visible, and the second is found as without the region.
TEST(IgnoreRegions, AnObjectInARegionIsNotReportedAndTheOtherIs) {
  sim::SceneConfig c;
  c.seed = 5;
  c.novelty_kinds = {sim::NoveltyKind::kBox, sim::NoveltyKind::kCylinder};
  const sim::ScenePair s = sim::generateScenePair(c);
  ASSERT_EQ(s.objects.size(), 2u);
  const int ignored_id = s.objects[0].id, other_id = s.objects[1].id;
  Params p;
  Pipeline plain(p);
  plain.setReference(s.reference);
  const Result before = plain.detect(s.current);
  const std::size_t other_points =
      std::count(s.current_labels.begin(), s.current_labels.end(), other_id);
  ASSERT_GT(labelledOn(before, s.current_labels, ignored_id), 0u);
  const std::size_t other_before = labelledOn(before, s.current_labels, other_id);
  ASSERT_GE(other_before, 0.8 * other_points);

  p.preprocess.ignore_regions = regionAround(s.current, s.current_labels, ignored_id, 0.05);
  const auto regions = parseIgnoreRegions(p.preprocess.ignore_regions);
  std::size_t inside = 0;
  for (const PointT& q : s.current)
    inside += std::isfinite(q.x) && inIgnoreRegion(regions, q.getVector3fMap().cast<double>());
  Pipeline ignoring(p);
  ignoring.setReference(s.reference);
  const Result after = ignoring.detect(s.current);
  EXPECT_EQ(after.ignored_points, inside);
  EXPECT_EQ(labelledOn(after, s.current_labels, ignored_id), 0u);
  for (std::size_t i = 0; i < s.current.size(); ++i) {
    if (!inIgnoreRegion(regions, s.current[i].getVector3fMap().cast<double>())) continue;
    EXPECT_EQ(after.labels[i], 0) << i;
    EXPECT_EQ(after.newly_visible[i], 0) << i;
  }
  EXPECT_GE(labelledOn(after, s.current_labels, other_id), 0.95 * other_before);
  EXPECT_EQ(after.segments.size() + 1, before.segments.size());
}

// A removed box (a box scene read backwards): reported as a disappearance, and not once a
// region covers it.
TEST(IgnoreRegions, ADisappearanceCentredInARegionIsDropped) {
  sim::SceneConfig c;
  c.seed = 3;
  c.novelty_kinds = {sim::NoveltyKind::kBox};
  const sim::ScenePair s = sim::generateScenePair(c);
  Params p;
  Pipeline plain(p);
  plain.setReference(s.current);
  const Result before = plain.detect(s.reference);
  ASSERT_TRUE(before.disappearances_checked);
  ASSERT_GE(before.disappeared_segments.size(), 1u);
  const std::size_t gone_before = before.disappeared_segments.size();

  p.preprocess.ignore_regions = regionAround(s.current, s.current_labels, s.objects[0].id, 0.1);
  Pipeline ignoring(p);
  ignoring.setReference(s.current);
  const Result after = ignoring.detect(s.reference);
  EXPECT_GE(after.ignored_disappearances, 1u);
  EXPECT_EQ(after.disappeared_segments.size() + after.ignored_disappearances, gone_before);
  const auto regions = parseIgnoreRegions(p.preprocess.ignore_regions);
  for (const Segment& g : after.disappeared_segments)
    EXPECT_FALSE(inIgnoreRegion(regions, g.centroid));
  for (std::size_t i = 0; i < s.current.size(); ++i)
    if (s.current_labels[i] > 0) EXPECT_EQ(after.disappeared_labels[i], 0) << i;
  for (const Superquadric& sq : after.disappeared_superquadrics) {
    bool live = false;
    for (const Segment& g : after.disappeared_segments) live |= g.id == sq.segment;
    EXPECT_TRUE(live);
  }
}
