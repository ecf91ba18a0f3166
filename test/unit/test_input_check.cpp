// Absurd coordinates are missing points, not data; a sweep off the map or of no extent is
// refused with a reason, never answered with "no change".
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "novelty_detection/pipeline.h"
#include "novelty_detection/preprocess/input_check.h"
#include "synthetic_scene.h"

using namespace novelty_detection;

namespace {

synthetic::Scene corridor(unsigned seed, bool objects) {
  synthetic::SceneOptions o;
  o.points = 8000;
  o.range_sigma_m = 0.005;
  o.seed = seed;
  if (!objects) o.objects.clear();
  return synthetic::makeCorridor(o);
}

Params fastParams() {
  Params p;
  p.superquadric.enabled = false;
  return p;
}

}  // namespace

TEST(InputCheck, UsablePointBounds) {
  EXPECT_TRUE(usablePoint(PointT(1e5f, -1e5f, 0.f)));
  EXPECT_FALSE(usablePoint(PointT(-9.3e19f, 0.f, 0.f)));
  EXPECT_FALSE(usablePoint(PointT(0.f, 0.f, std::numeric_limits<float>::quiet_NaN())));
  EXPECT_FALSE(usablePoint(PointT(0.f, std::numeric_limits<float>::infinity(), 0.f)));
  Cloud c;
  c.push_back(PointT(0, 0, 0));
  c.push_back(PointT(3e19f, 0, 0));
  c.push_back(PointT(NAN, 0, 0));
  EXPECT_EQ(countOutOfRange(c), 1u);
  const Cloud w = withoutOutOfRange(c);
  ASSERT_EQ(w.size(), 3u);
  EXPECT_TRUE(usablePoint(w[0]));
  EXPECT_TRUE(std::isnan(w[1].x));
}

// One point at 3e19 m used to make outlier removal drop every point: now it is one missing
// point, the labels of the rest are the same as without it, and the result says so.
TEST(InputCheck, OneAbsurdPointChangesNothingElse) {
  const synthetic::Scene ref = corridor(1, false);
  const synthetic::Scene cur = corridor(2, true);
  Pipeline pipeline(fastParams());
  pipeline.setReference(ref.cloud);
  const Result clean = pipeline.detect(cur.cloud);
  ASSERT_FALSE(clean.segments.empty());
  Cloud bad = cur.cloud;
  bad[17].x = 3e19f;
  bad[18].y = -9.3e19f;
  const Result r = pipeline.detect(bad);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_NE(r.warnings[0].find("2 sweep points"), std::string::npos) << r.warnings[0];
  EXPECT_EQ(r.segments.size(), clean.segments.size());
  std::size_t differ = 0;
  for (std::size_t i = 0; i < r.labels.size(); ++i)
    differ += i != 17 && i != 18 && (r.labels[i] != 0) != (clean.labels[i] != 0);
  EXPECT_LE(differ, 5u);
  EXPECT_EQ(r.labels[17], 0);
  // The same in the reference.
  Cloud bad_ref = ref.cloud;
  bad_ref[5].z = 1e20f;
  Pipeline p2(fastParams());
  p2.setReference(bad_ref);
  const Result r2 = p2.detect(cur.cloud);
  ASSERT_EQ(r2.warnings.size(), 1u);
  EXPECT_NE(r2.warnings[0].find("1 reference points"), std::string::npos);
  EXPECT_EQ(r2.segments.size(), clean.segments.size());
}

TEST(InputCheck, SweepOffTheMapIsRefused) {
  const synthetic::Scene ref = corridor(1, false);
  Cloud far = corridor(2, true).cloud;
  for (PointT& p : far) p.x += 500.0f;
  Pipeline pipeline(fastParams());
  pipeline.setReference(ref.cloud);
  try {
    pipeline.detect(far);
    FAIL() << "a sweep 500 m off the map was compared";
  } catch (const NoOverlapError& e) {
    EXPECT_NE(std::string(e.what()).find("does not overlap the reference"), std::string::npos)
        << e.what();
    EXPECT_LT(e.overlap(), 0.01);
  }
  // The same place: nearly every point is near the map.
  const Result same = pipeline.detect(corridor(2, true).cloud);
  EXPECT_GT(same.overlap, 0.9);
  // Half off the map (a robot at the map's edge) is still compared, and says so.
  Cloud half = corridor(2, true).cloud;
  for (PointT& p : half) p.x += 6.0f;
  Result r;
  EXPECT_NO_THROW(r = pipeline.detect(half));
  EXPECT_GT(r.overlap, 0.1);
  EXPECT_LT(r.overlap, 0.8);
}

TEST(InputCheck, SweepInsideTheExtentButAwayFromTheMapIsRefused) {
  // Every point inside the map's box, none near its surfaces: the sweep shrunk to a third
  // about the box's centre (a wrong frame or scale), so the extent test alone would pass.
  const synthetic::Scene ref = corridor(1, false);
  Eigen::Vector3f lo = ref.cloud[0].getVector3fMap(), hi = lo;
  for (const PointT& p : ref.cloud) {
    lo = lo.cwiseMin(p.getVector3fMap());
    hi = hi.cwiseMax(p.getVector3fMap());
  }
  const Eigen::Vector3f centre = 0.5f * (lo + hi);
  Cloud shrunk = corridor(2, true).cloud;
  for (PointT& p : shrunk) p.getVector3fMap() = centre + (p.getVector3fMap() - centre) / 3.0f;
  Pipeline pipeline(fastParams());
  pipeline.setReference(ref.cloud);
  try {
    pipeline.detect(shrunk);
    FAIL() << "a sweep away from every surface of the map was compared";
  } catch (const NoOverlapError& e) {
    EXPECT_LT(e.overlap(), kMinOverlap);
    EXPECT_NE(std::string(e.what()).find("overlap"), std::string::npos) << e.what();
  }
}

TEST(InputCheck, ReferenceOfNoExtentIsRefused) {
  Cloud tiny = corridor(1, false).cloud;
  for (PointT& p : tiny) p.getVector3fMap() *= 1e-40f;  // denormals: all in one place
  Pipeline pipeline(fastParams());
  try {
    pipeline.setReference(tiny);
    FAIL() << "a reference of no extent was taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("all in one place"), std::string::npos) << e.what();
  }
  // A sweep shrunk so lies off a map that does not hold the origin: refused as off the map.
  Cloud ref = corridor(1, false).cloud;
  for (PointT& p : ref) p.x += 100.0f;
  pipeline.setReference(ref);
  EXPECT_THROW(pipeline.detect(tiny), std::runtime_error);
}
