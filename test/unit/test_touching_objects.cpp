// Objects that touch are separate objects (segmentation/surface_creases.h): two new boxes
// pushed together, and two new cylinders standing against each other, seen by a dense,
// low-noise sweep (a fine tilting laser, 2 mm range noise), each come out as their own
// segment; the same scenes with the crease rule off merge them. A plane is never a crease,
// a box's convex edge neither; the valley where a box meets a wall is.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <memory>

#include "novelty_detection/eval/evaluation.h"
#include "novelty_detection/pipeline.h"
#include "novelty_detection/segmentation/surface_creases.h"
#include "novelty_detection/sim/laser.h"
#include "novelty_detection/sim/primitives.h"
#include "novelty_detection/sim/world.h"

using namespace novelty_detection;
using namespace novelty_detection::sim;

namespace {

/// A room corner: the floor, a back wall at x = 4 and a side wall at y = -3.
World room() {
  World w;
  w.add(std::make_shared<Plane>(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ()));
  w.add(std::make_shared<Plane>(Eigen::Vector3d(4, 0, 0), -Eigen::Vector3d::UnitX()));
  w.add(std::make_shared<Plane>(Eigen::Vector3d(0, -3, 0), Eigen::Vector3d::UnitY()));
  return w;
}

/// A dense tilting laser: 0.2 degree steps, 140 lines over 55 degrees, 2 mm noise.
LaserConfig denseLaser() {
  LaserConfig c;
  c.fov_deg = 90.0;
  c.step_deg = 0.2;
  c.lines = 140;
  c.tilt_min_deg = 10.0;
  c.tilt_max_deg = 65.0;
  c.mount_height_m = 1.6;
  c.noise_variance_m2 = 4e-6;
  return c;
}

std::shared_ptr<OrientedBox> box(double x0, double x1, double y0, double y1, double h, int id) {
  return std::make_shared<OrientedBox>(Eigen::Vector3d((x0 + x1) / 2, (y0 + y1) / 2, h / 2),
                                       Eigen::Matrix3d::Identity(),
                                       Eigen::Vector3d((x1 - x0) / 2, (y1 - y0) / 2, h / 2), id);
}

struct Outcome {
  SceneScore score;
  std::size_t segments = 0;
};

/// Reference: the room; current: the room with `objects`, both from the same pose.
Outcome detect(const World& objects, double crease_offset_factor) {
  const World ref_world = room();
  World cur_world = room();
  cur_world.add(objects);
  const Eigen::Isometry3d pose = sensorPose(0.0, 0.8, -0.3, denseLaser().mount_height_m);
  const TiltScan ref = simulateTiltScan(ref_world, pose, denseLaser(), 1);
  const TiltScan cur = simulateTiltScan(cur_world, pose, denseLaser(), 2);
  Params p;
  p.superquadric.enabled = false;
  p.segmentation.crease_offset_factor = crease_offset_factor;
  Pipeline pipeline(p);
  pipeline.setReference(ref.cloud);
  const Result r = pipeline.detect(cur.cloud);
  return {scoreLabels(r.labels, cur.labels), r.segments.size()};
}

void expectApart(const Outcome& o, const char* what) {
  ASSERT_EQ(o.score.objects.size(), 2u) << what;
  for (const ObjectScore& obj : o.score.objects) {
    EXPECT_GE(obj.best_iou, 0.8) << what << ": object " << obj.id;
  }
  EXPECT_NE(o.score.objects[0].best_segment, o.score.objects[1].best_segment) << what;
  EXPECT_GE(o.score.f1, 0.9) << what;
}

}  // namespace

// A parcel pushed against a taller, wider cabinet: the parcel's top and side meet the
// cabinet's front in valleys.
TEST(TouchingObjects, TwoBoxesAreTwoSegments) {
  World objects;
  objects.add(box(1.4, 1.8, -0.3, 0.3, 0.4, 1));
  objects.add(box(1.8, 2.2, -0.45, 0.45, 0.8, 2));
  const Outcome with = detect(objects, 3.0);
  expectApart(with, "boxes");
  // Without the crease rule the two are one object and one segment.
  const Outcome without = detect(objects, 0.0);
  ASSERT_EQ(without.score.objects.size(), 2u);
  EXPECT_EQ(without.score.objects[0].best_segment, without.score.objects[1].best_segment);
}

// Two upright cylinders standing against each other (radii 0.2 and 0.15 m, touching).
TEST(TouchingObjects, TwoCylindersAreTwoSegments) {
  World objects;
  objects.add(std::make_shared<Cylinder>(Eigen::Vector3d(1.7, -0.2, 0.35),
                                         Eigen::Matrix3d::Identity(), 0.2, 0.35, 1));
  objects.add(std::make_shared<Cylinder>(Eigen::Vector3d(1.7, 0.15, 0.25),
                                         Eigen::Matrix3d::Identity(), 0.15, 0.25, 2));
  expectApart(detect(objects, 3.0), "cylinders");
  const Outcome without = detect(objects, 0.0);
  ASSERT_EQ(without.score.objects.size(), 2u);
  EXPECT_EQ(without.score.objects[0].best_segment, without.score.objects[1].best_segment);
}

// The rule itself on noise-free samples: a plane has no crease, a box's convex edge none,
// and the valley where a floor meets a wall (seen from the room) is one.
TEST(CreaseTest, ValleysAreCreasesPlanesAndRidgesAreNot) {
  Cloud c;
  // Floor z = 0 for x in [0, 1], wall x = 1 for z in [0, 1] (a valley along x = 1, z = 0),
  // and a box edge (ridge) at x = 0, z = 0 going down: the floor's front edge folds to a
  // face x = 0 below it.
  for (int i = 0; i <= 50; ++i)
    for (int j = 0; j <= 50; ++j) {
      c.push_back(PointT(0.02f * i, 0.02f * j, 0.0f));              // floor
      c.push_back(PointT(1.0f, 0.02f * j, 0.02f * i));              // wall
      if (i > 0) c.push_back(PointT(0.0f, 0.02f * j, -0.02f * i));  // face below the ridge
    }
  c.width = c.size(), c.height = 1;
  Indices kept(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) kept[i] = static_cast<int>(i);
  NearestNeighbourIndex index;
  index.build(c, kept);
  const Eigen::Vector3f sensor(-0.5f, 0.5f, 1.5f);  // above the floor, in front of the wall
  CreaseTest creases(c, kept, index, sensor, 0.1, 3.0, [](double) { return 0.002; });
  auto at = [&](float x, float y, float z) {
    for (std::size_t i = 0; i < c.size(); ++i)
      if ((c[i].getVector3fMap() - Eigen::Vector3f(x, y, z)).norm() < 1e-4f)
        return creases.inCrease(static_cast<int>(i));
    ADD_FAILURE() << "no sample at " << x << " " << y << " " << z;
    return false;
  };
  EXPECT_FALSE(at(0.5f, 0.5f, 0.0f));  // floor
  EXPECT_FALSE(at(1.0f, 0.5f, 0.5f));  // wall
  EXPECT_TRUE(at(1.0f, 0.5f, 0.0f));   // where they meet
  EXPECT_TRUE(at(0.98f, 0.5f, 0.0f));  // beside it
  EXPECT_FALSE(at(0.0f, 0.5f, 0.0f));  // the ridge
  // Answered ahead on two threads (every other point, with its neighbours), the answers
  // are the ones asked one by one: some creases, most not.
  const auto sigma = [](double) { return 0.002; };
  CreaseTest serial(c, kept, index, sensor, 0.1, 3.0, sigma, 0.03);
  CreaseTest ahead(c, kept, index, sensor, 0.1, 3.0, sigma, 0.03);
  std::vector<int> some;
  for (int k = 0; k < static_cast<int>(c.size()); k += 2) some.push_back(k);
  ahead.prepare(some, 2);
  std::size_t near = 0;
  for (int k = 0; k < static_cast<int>(c.size()); ++k) {
    const bool a = serial.nearCrease(k), b = ahead.nearCrease(k);
    ASSERT_EQ(a, b) << "point " << k;
    ASSERT_EQ(serial.inCrease(k), ahead.inCrease(k)) << "point " << k;
    near += a;
  }
  EXPECT_GT(near, 50u);
  EXPECT_LT(near, c.size() / 4);
  // Without a noise estimate nothing is a crease.
  CreaseTest blind(c, kept, index, sensor, 0.1, 3.0, [](double) { return 0.0; });
  std::size_t found = 0;
  for (std::size_t i = 0; i < c.size(); ++i) found += blind.inCrease(static_cast<int>(i));
  EXPECT_EQ(found, 0u);
}
