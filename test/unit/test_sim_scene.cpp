// Simulated scene pairs: determinism, ground truth consistent with the geometry, placement.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>

#include "novelty_detection/sim/scene.h"

using namespace novelty_detection;
using namespace novelty_detection::sim;

namespace {

bool sameCloud(const Cloud& a, const Cloud& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (a[i].x != b[i].x || a[i].y != b[i].y || a[i].z != b[i].z) return false;
  return true;
}

// Eq. 2 written out independently of the simulator's code.
double insideOutside(const Superquadric& sq, const Eigen::Vector3d& p_world) {
  const Eigen::Vector3d p = sq.rotation().transpose() * (p_world - sq.position);
  const double x = std::pow(std::abs(p.x() / sq.a.x()), 2.0 / sq.e2);
  const double y = std::pow(std::abs(p.y() / sq.a.y()), 2.0 / sq.e2);
  const double z = std::pow(std::abs(p.z() / sq.a.z()), 2.0 / sq.e1);
  return std::pow(x + y, sq.e2 / sq.e1) + z;
}

// Distance-like residual of a point to a part's surface: |F^(e1/2) - 1| times the smallest
// size for exact superquadrics (the gauge is homogeneous of degree 1), the largest signed
// face gap for boxes and cylinders (0 on their surface).
double surfaceResidual(const ObjectPart& part, const Eigen::Vector3d& p_world) {
  const Superquadric& sq = part.sq;
  const Eigen::Vector3d q = sq.rotation().transpose() * (p_world - sq.position);
  if (part.sq_exact)
    return std::abs(std::pow(insideOutside(sq, p_world), 0.5 * sq.e1) - 1.0) * sq.a.minCoeff();
  if (part.shape == "box") return std::abs((q.cwiseAbs() - sq.a).maxCoeff());
  if (part.shape == "cylinder")
    return std::abs(std::max(q.head<2>().norm() - sq.a.x(), std::abs(q.z()) - sq.a.z()));
  ADD_FAILURE() << "unknown shape " << part.shape;
  return 1e9;
}

}  // namespace

TEST(SimScene, SameSeedSameScenesOtherSeedOtherScenes) {
  SceneConfig c;
  c.seed = 21;
  c.novelty_kinds = {NoveltyKind::kBox, NoveltyKind::kSphere};
  const ScenePair a = generateScenePair(c), b = generateScenePair(c);
  EXPECT_TRUE(sameCloud(a.reference, b.reference));
  EXPECT_TRUE(sameCloud(a.current, b.current));
  EXPECT_EQ(a.current_labels, b.current_labels);
  c.seed = 22;
  const ScenePair d = generateScenePair(c);
  EXPECT_FALSE(sameCloud(a.current, d.current));
  EXPECT_FALSE(sameCloud(a.reference, d.reference));
}

TEST(SimScene, CorridorSweepHasAboutThirtyThousandPointsAndVisibleObjects) {
  SceneConfig c;
  c.seed = 4;
  c.novelty_kinds = {NoveltyKind::kPerson, NoveltyKind::kCylinder, NoveltyKind::kDoorAngle};
  const ScenePair s = generateScenePair(c);
  const int beams = c.laser.lines * c.laser.beamsPerLine();
  EXPECT_GT(static_cast<int>(s.current.size()), 0.9 * beams);
  EXPECT_LE(static_cast<int>(s.current.size()), beams);
  EXPECT_GT(static_cast<int>(s.reference.size()), 0.9 * beams);
  ASSERT_EQ(s.current_labels.size(), s.current.size());
  ASSERT_EQ(s.objects.size(), 3u);
  std::map<int, int> counts;
  for (int l : s.current_labels) ++counts[l];
  for (std::size_t k = 0; k < s.objects.size(); ++k) {
    EXPECT_EQ(s.objects[k].id, static_cast<int>(k) + 1);
    EXPECT_EQ(s.objects[k].points, counts[s.objects[k].id]);
    EXPECT_GE(s.objects[k].points, c.min_object_points);
  }
  EXPECT_EQ(s.objects[0].parts.size(), 8u);  // head, torso, 2 arms, 2 legs, 2 feet
  EXPECT_GE(std::abs(s.objects[2].door_angle_current_rad - s.objects[2].door_angle_reference_rad),
            40.0 * M_PI / 180.0 - 1e-9);
  // Floor at z = 0, all points inside the building.
  for (const auto& p : s.current) {
    EXPECT_GT(p.z, -0.2f);
    EXPECT_LT(p.z, 3.2f);
  }
}

TEST(SimScene, LabelledPointsLieOnTheirObjectsWithoutNoise) {
  const std::vector<NoveltyKind> corridor_kinds = {
      NoveltyKind::kSphere, NoveltyKind::kSuperellipsoid, NoveltyKind::kMovedObject};
  const std::vector<NoveltyKind> office_kinds = {NoveltyKind::kPerson, NoveltyKind::kCylinder,
                                                 NoveltyKind::kDoorAngle};
  for (auto layout : {Layout::kCorridor, Layout::kOffice}) {
    SceneConfig c;
    c.seed = 9;
    c.layout = layout;
    c.laser.noise_variance_m2 = 0.0;
    c.novelty_kinds = layout == Layout::kCorridor ? corridor_kinds : office_kinds;
    const ScenePair s = generateScenePair(c);
    ASSERT_EQ(s.objects.size(), 3u) << toString(layout);
    const Eigen::Vector3d origin = s.T_world_sensor_current.translation();
    std::map<int, int> checked;
    for (std::size_t i = 0; i < s.current.size(); ++i) {
      const int k = s.current_labels[i];
      const Eigen::Vector3d p = s.current[i].getVector3fMap().cast<double>();
      // The ray to the point hits that object first, at the point's range.
      const auto hit = s.current_world.intersect(Ray{origin, (p - origin).normalized()});
      ASSERT_TRUE(hit);
      EXPECT_EQ(hit->object_id, k);
      EXPECT_NEAR(hit->t, (p - origin).norm(), 1e-4);
      if (k == 0) continue;
      // On the surface of one of the described parts (float coordinates: ~1e-6 m).
      const ObjectDescription& o = s.objects[k - 1];
      double best = 1e9;
      for (const ObjectPart& part : o.parts) best = std::min(best, surfaceResidual(part, p));
      EXPECT_LT(best, 1e-4) << toString(o.kind);
      ++checked[k];
    }
    EXPECT_EQ(checked.size(), 3u);
    // Objects stand on the floor: their lowest part touches z = 0.
    for (const auto& o : s.objects) {
      if (o.kind == NoveltyKind::kDoorAngle) continue;  // hangs 1 cm above it
      double bottom = 1e9;
      for (const auto& part : o.parts) {
        const auto& sq = part.sq;
        bottom = std::min(bottom, o.kind == NoveltyKind::kSuperellipsoid && sq.euler.y() != 0.0
                                      ? sq.position.z() - sq.a.x()
                                      : sq.position.z() - sq.a.z());
      }
      EXPECT_NEAR(bottom, 0.0, 1e-9) << toString(o.kind);
    }
  }
}

TEST(SimScene, PoseOffsetMovesTheCurrentSensor) {
  SceneConfig c;
  c.seed = 2;
  c.laser.lines = 6;  // geometry only: keep it cheap
  c.min_object_points = 5;
  c.pose_offset = Eigen::Vector3d(0.2, -0.1, 5.0 * M_PI / 180.0);
  const ScenePair s = generateScenePair(c);
  const Eigen::Isometry3d rel = s.T_world_sensor_reference.inverse() * s.T_world_sensor_current;
  EXPECT_NEAR(rel.translation().x(), 0.2, 1e-12);
  EXPECT_NEAR(rel.translation().y(), -0.1, 1e-12);
  EXPECT_NEAR(rel.translation().z(), 0.0, 1e-12);
  EXPECT_NEAR(Eigen::AngleAxisd(rel.linear()).angle(), 5.0 * M_PI / 180.0, 1e-12);
  EXPECT_NEAR(s.T_world_sensor_reference.translation().z(), c.laser.mount_height_m, 1e-12);
  c.pose_offset = Eigen::Vector3d(2.0, 0, 0);
  EXPECT_THROW(generateScenePair(c), std::invalid_argument);
}

TEST(SimScene, PoseOffsetIntoAWallIsRefused) {
  // Offices put the robot 1.0-1.6 m from the wall behind it: a 1 m step back hits the 0.3 m
  // margin for part of the seeds.
  int refused = 0, accepted = 0;
  for (std::uint64_t seed = 1; seed <= 12; ++seed) {
    SceneConfig c;
    c.seed = seed;
    c.layout = Layout::kOffice;
    c.laser.lines = 3;
    c.novelty_count = 0;
    c.pose_offset = Eigen::Vector3d(-1.0, 0.0, 0.0);
    try {
      const ScenePair s = generateScenePair(c);
      EXPECT_GE(s.base_pose_current.x(), 0.3);
      EXPECT_TRUE(s.objects.empty());
      ++accepted;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("pose_offset"), std::string::npos);
      ++refused;
    }
  }
  EXPECT_GT(refused, 0);
  EXPECT_GT(accepted, 0);
}

TEST(SimScene, SuiteConfigsAreVariedAndDeterministic) {
  std::set<NoveltyKind> kinds;
  std::set<Layout> layouts;
  int with_offset = 0;
  for (int i = 0; i < 30; ++i) {
    const SceneConfig c = suiteSceneConfig(i, 1);
    const SceneConfig again = suiteSceneConfig(i, 1);
    EXPECT_EQ(c.seed, again.seed);
    EXPECT_EQ(c.novelty_kinds, again.novelty_kinds);
    EXPECT_NE(c.seed, suiteSceneConfig(i, 2).seed);
    EXPECT_GE(c.novelty_kinds.size(), 1u);
    EXPECT_LE(c.novelty_kinds.size(), 3u);
    kinds.insert(c.novelty_kinds.begin(), c.novelty_kinds.end());
    layouts.insert(c.layout);
    const double m = c.pose_offset.head<2>().norm();
    if (m > 0) {
      ++with_offset;
      EXPECT_GE(m, 0.05 - 1e-12);
      EXPECT_LE(m, 0.30 + 1e-12);
      EXPECT_LE(std::abs(c.pose_offset.z()), 10.0 * M_PI / 180.0);
    }
    EXPECT_NO_THROW(c.validate());
  }
  EXPECT_EQ(kinds.size(), allNoveltyKinds().size());
  EXPECT_EQ(layouts.size(), 2u);
  EXPECT_EQ(with_offset, 10);
}

TEST(SimScene, NamesRoundTripAndBadNamesThrow) {
  for (NoveltyKind k : allNoveltyKinds()) EXPECT_EQ(noveltyKindFromString(toString(k)), k);
  EXPECT_EQ(layoutFromString("office"), Layout::kOffice);
  EXPECT_THROW(layoutFromString("kitchen"), std::invalid_argument);
  EXPECT_THROW(noveltyKindFromString("cat"), std::invalid_argument);
}

TEST(SimScene, DefaultSuitePlacesEveryPlannedNovelty) {
  // The 30 scenes of `simulate_scans --suite 30` (suite seed 1) keep all their novelties,
  // each with enough points, and all sweeps have about 30k points.
  for (int i = 0; i < 30; ++i) {
    const SceneConfig c = suiteSceneConfig(i, 1);
    const ScenePair s = generateScenePair(c);
    EXPECT_EQ(s.objects.size(), c.novelty_kinds.size()) << "scene " << i;
    for (const auto& o : s.objects) EXPECT_GE(o.points, c.min_object_points) << "scene " << i;
    EXPECT_GT(s.current.size(), 29000u) << "scene " << i;
  }
}
