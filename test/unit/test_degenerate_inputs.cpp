// Degenerate geometry through the whole Pipeline: every case either yields a result whose
// labels match the input and whose numbers are all finite, or a std::invalid_argument /
// std::logic_error naming the problem. Never a crash, a NaN or a hang.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <vector>

#include "novelty_detection/pipeline.h"
#include "novelty_detection/preprocess/input_check.h"
#include "novelty_detection/sim/scene.h"

using namespace novelty_detection;

namespace {

bool finite(const Eigen::MatrixXd& m) { return m.allFinite(); }

// Checks every number a caller may read from a result, and the label/segment agreement.
void expectSaneResult(const Result& r, std::size_t n) {
  ASSERT_EQ(r.labels.size(), n);
  for (int l : r.labels) ASSERT_GE(l, 0);
  EXPECT_TRUE(std::isfinite(r.emd_before)) << r.emd_before;
  EXPECT_TRUE(std::isfinite(r.emd_after)) << r.emd_after;
  EXPECT_EQ(r.novel_gaussian.size(), r.current_gmm.size());
  for (const Gaussian& g : r.current_gmm.components) {
    EXPECT_TRUE(std::isfinite(g.weight));
    EXPECT_TRUE(finite(g.mean));
    EXPECT_TRUE(finite(g.cov));
  }
  std::size_t labelled = 0;
  for (int l : r.labels) labelled += l > 0;
  std::size_t in_segments = 0;
  for (const Segment& s : r.segments) {
    EXPECT_GT(s.id, 0);
    EXPECT_TRUE(finite(s.centroid) && finite(s.bbox_min) && finite(s.bbox_max));
    EXPECT_TRUE(std::isfinite(s.emd_contribution));
    for (int i : s.indices) {
      ASSERT_GE(i, 0);
      ASSERT_LT(static_cast<std::size_t>(i), n);
      EXPECT_EQ(r.labels[i], s.id);
    }
    in_segments += s.indices.size();
  }
  EXPECT_EQ(labelled, in_segments);
  for (const Superquadric& q : r.superquadrics) {
    EXPECT_TRUE(finite(q.a) && finite(q.euler) && finite(q.position));
    EXPECT_TRUE(std::isfinite(q.e1) && std::isfinite(q.e2) && std::isfinite(q.residual));
    EXPECT_GT(q.a.minCoeff(), 0.0);
  }
}

std::size_t labelledCount(const Result& r) {
  std::size_t k = 0;
  for (int l : r.labels) k += l > 0;
  return k;
}

class DegenerateCurrent : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    sim::SceneConfig c;
    c.seed = 11;  // the unchanged scene of test_pipeline NoChangeNoNovelty
    c.novelty_count = 0;
    scene_ = new sim::ScenePair(sim::generateScenePair(c));
    pipeline_ = new Pipeline(Params());
    pipeline_->setReference(scene_->reference);
  }
  static void TearDownTestSuite() {
    delete pipeline_;
    delete scene_;
  }
  // A point of the map (a wall or the floor): clouds built around it lie on known geometry.
  static PointT mapPoint(std::size_t i) { return scene_->reference[i % scene_->reference.size()]; }

  static sim::ScenePair* scene_;
  static Pipeline* pipeline_;
};
sim::ScenePair* DegenerateCurrent::scene_ = nullptr;
Pipeline* DegenerateCurrent::pipeline_ = nullptr;

Cloud line(const Eigen::Vector3f& a, const Eigen::Vector3f& b, int n) {
  Cloud c;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3f p = a + (b - a) * (static_cast<float>(i) / (n - 1));
    c.push_back(PointT(p.x(), p.y(), p.z()));
  }
  return c;
}

}  // namespace

TEST_F(DegenerateCurrent, CoplanarPatchInFreeSpace) {
  // 40 x 40 points on a 1 m square, all at one height: a plane with no thickness.
  Cloud c;
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j) c.push_back(PointT(1.0f + 0.025f * i, 0.5f + 0.025f * j, 1.0f));
  expectSaneResult(pipeline_->detect(c), c.size());
}

TEST_F(DegenerateCurrent, CollinearPoints) {
  // A line in mid-air and nothing else: no point is near the map, so it cannot be compared.
  const Cloud c = line({0.5f, 0.0f, 1.0f}, {2.5f, 0.0f, 1.0f}, 500);
  try {
    pipeline_->detect(c);
    FAIL() << "a sweep with no point near the map was compared";
  } catch (const NoOverlapError& e) {
    EXPECT_LT(e.overlap(), kMinOverlap);
  }
  // The same line beside as many points of the map is compared.
  Cloud mixed = c;
  for (std::size_t i = 0; i < c.size(); ++i) mixed.push_back(mapPoint(7 * i));
  expectSaneResult(pipeline_->detect(mixed), mixed.size());
}

TEST_F(DegenerateCurrent, SinglePointAndTwoPoints) {
  Cloud one;
  one.push_back(mapPoint(10));
  const Result r1 = pipeline_->detect(one);
  expectSaneResult(r1, 1);
  // One or two points cannot support a Gaussian of their own: nothing is reported.
  EXPECT_FALSE(r1.hasNovelty());
  Cloud two = one;
  two.push_back(mapPoint(4000));
  const Result r2 = pipeline_->detect(two);
  expectSaneResult(r2, 2);
  EXPECT_FALSE(r2.hasNovelty());
}

TEST_F(DegenerateCurrent, FewerPointsThanGaussians) {
  ASSERT_GT(pipeline_->referenceGmm().size(), 5u);
  Cloud c;
  for (int i = 0; i < 5; ++i) c.push_back(mapPoint(97 * i));
  const Result r = pipeline_->detect(c);
  expectSaneResult(r, c.size());
  EXPECT_FALSE(r.hasNovelty());
}

TEST_F(DegenerateCurrent, DuplicatePoints) {
  // 2000 copies of one point of the map: zero covariance everywhere, no novelty.
  Cloud c;
  for (int i = 0; i < 2000; ++i) c.push_back(mapPoint(1234));
  const Result r = pipeline_->detect(c);
  expectSaneResult(r, c.size());
  EXPECT_FALSE(r.hasNovelty());
  // The whole sweep given twice (every point repeated) is still the unchanged scene.
  Cloud twice = scene_->current;
  twice += scene_->current;
  const Result r2 = pipeline_->detect(twice);
  expectSaneResult(r2, twice.size());
  EXPECT_EQ(labelledCount(r2), 0u);
}

TEST(DuplicatedSweep, RepeatedPointsShareTheirTwinsLabel) {
  // A sweep with a novelty, then the same sweep appended to itself: the detection is the
  // same, and each copy of a point carries the label of the point it repeats.
  sim::SceneConfig c;
  c.seed = 5;
  c.novelty_kinds = {sim::NoveltyKind::kBox};
  const sim::ScenePair s = sim::generateScenePair(c);
  Pipeline pipeline{Params()};
  pipeline.setReference(s.reference);
  const Result once = pipeline.detect(s.current);
  ASSERT_TRUE(once.hasNovelty());
  Cloud twice = s.current;
  twice += s.current;
  const Result r = pipeline.detect(twice);
  expectSaneResult(r, twice.size());
  const std::size_t n = s.current.size();
  std::size_t same = 0;
  for (std::size_t i = 0; i < n; ++i) {
    EXPECT_EQ(r.labels[i], r.labels[i + n]) << i;
    same += (r.labels[i] > 0) == (once.labels[i] > 0);
  }
  EXPECT_EQ(same, n);
  EXPECT_EQ(r.segments.size(), once.segments.size());
}

TEST_F(DegenerateCurrent, HugeCoordinates) {
  // The sweep moved 1000 km away (float resolution there is ~6 cm): a clear error or a
  // finite result, never NaN.
  Cloud c = scene_->current;
  for (auto& p : c.points) {
    p.x += 1e6f;
    p.y -= 1e6f;
  }
  try {
    expectSaneResult(pipeline_->detect(c), c.size());
  } catch (const std::invalid_argument& e) {
    SUCCEED() << e.what();
  }
  Cloud far;
  far.push_back(PointT(1e6f, 1e6f, 1e6f));
  far.push_back(PointT(-1e6f, 1e6f, 0.0f));
  far.push_back(PointT(3e38f, 0.0f, 0.0f));  // finite, but its square overflows a float
  expectSaneResult(pipeline_->detect(far), far.size());
}

TEST_F(DegenerateCurrent, TinyCloud) {
  // 300 points inside a 1 micrometre cube next to the map.
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 1e-6f);
  const PointT o = mapPoint(50);
  Cloud c;
  for (int i = 0; i < 300; ++i) c.push_back(PointT(o.x + u(rng), o.y + u(rng), o.z + u(rng)));
  const Result r = pipeline_->detect(c);
  expectSaneResult(r, c.size());
  EXPECT_FALSE(r.hasNovelty());
}

TEST_F(DegenerateCurrent, InfinitePointsAreSkipped) {
  const float inf = std::numeric_limits<float>::infinity();
  Cloud c = scene_->current;
  c.points[3] = PointT(inf, 0.0f, 0.0f);
  c.points[7] = PointT(0.0f, -inf, std::numeric_limits<float>::quiet_NaN());
  const Result r = pipeline_->detect(c);
  expectSaneResult(r, c.size());
  EXPECT_EQ(r.labels[3], 0);
  EXPECT_EQ(r.labels[7], 0);
  EXPECT_FALSE(r.hasNovelty()) << labelledCount(r) << " points labelled";
}

TEST_F(DegenerateCurrent, TenMillionPointsAreRefusedBeforeAnyWork) {
  // 10M points > preprocess/max_points (2M): refused by size, before labels or any copy.
  Cloud c;
  c.resize(10000000);
  try {
    pipeline_->detect(c);
    FAIL() << "a 10M point cloud was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("max_points"), std::string::npos) << e.what();
  }
}

TEST(DegenerateReference, TooFewOrDegenerateMapPoints) {
  Pipeline p{Params()};
  Cloud one;
  one.push_back(PointT(1.0f, 2.0f, 3.0f));
  EXPECT_THROW(p.setReference(one), std::invalid_argument);
  EXPECT_FALSE(p.hasReference());
  Cloud nan;
  for (int i = 0; i < 100; ++i) nan.push_back(PointT(NAN, NAN, NAN));
  EXPECT_THROW(p.setReference(nan), std::invalid_argument);
  EXPECT_THROW(p.detect(one), std::logic_error);
}

TEST(DegenerateReference, PlanarAndCollinearMaps) {
  // A map that is only a floor (coplanar) or only a line: either refused with a clear error
  // or usable, and the same geometry scanned again is not novel.
  Cloud floor;
  for (int i = 0; i < 60; ++i)
    for (int j = 0; j < 60; ++j) floor.push_back(PointT(0.05f * i, 0.05f * j, 0.0f));
  const Cloud rail = line({0.0f, 0.0f, 0.0f}, {3.0f, 0.0f, 0.0f}, 600);
  for (const Cloud* map : std::vector<const Cloud*>{&floor, &rail}) {
    Pipeline p{Params()};
    try {
      p.setReference(*map);
    } catch (const std::invalid_argument& e) {
      SUCCEED() << e.what();
      continue;
    }
    for (const Gaussian& g : p.referenceGmm().components) {
      EXPECT_TRUE(std::isfinite(g.weight) && g.mean.allFinite() && g.cov.allFinite());
    }
    const Result r = p.detect(*map);
    expectSaneResult(r, map->size());
    EXPECT_FALSE(r.hasNovelty()) << labelledCount(r) << " points labelled";
  }
}
