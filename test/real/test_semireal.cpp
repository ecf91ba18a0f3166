// Semi-real scenes: a real person (cut from a real camera frame of people in a corridor) and
// a box ray-cast into the current sweep of a real laser pair along its own beams, at several
// free floor placements chosen by a seeded rule. Ground truth = the moved points. Each test
// prints one row of the real-data table per placement (scripts/evaluate_real.sh).
#include <gtest/gtest.h>

#include <pcl/io/pcd_io.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "../unit/synthetic_scene.h"
#include "novelty_detection/pipeline.h"
#include "novelty_detection/sim/semireal.h"
#include "real_data.h"

using namespace novelty_detection;
using namespace novelty_detection::real_data;

namespace {

sim::ObjectModel realPerson() {
  const fs::path path = dataDir() / "pcl_test_indoor_scenes" / "five_people.pcd";
  return sim::cutNearestPerson(loadCloud(path.string()));
}

/// The best intersection over union of one segment with the true points.
struct Found {
  double iou = 0.0;
  std::size_t segment_points = 0, truth_points = 0, segments = 0;
};

Found bestSegment(const Result& r, const std::vector<int>& truth) {
  Found f;
  f.segments = r.segments.size();
  for (int t : truth) f.truth_points += t != 0;
  for (const Segment& s : r.segments) {
    std::size_t both = 0;
    for (int i : s.indices) both += truth[i] != 0;
    const double iou = static_cast<double>(both) / (s.indices.size() + f.truth_points - both);
    if (iou > f.iou) f.iou = iou, f.segment_points = s.indices.size();
  }
  return f;
}

std::size_t groundPoints(const Result& r) {
  std::map<std::string, std::size_t> c(r.point_counts.begin(), r.point_counts.end());
  return c["after_outliers"] - c["after_ground"];
}

/// One inserted object: its best segment, the share of its points labelled, and whether the
/// floor is the one of the sweep without it (found alike; when found, the same plane within
/// 1 cm and 1 degree, and as many ground points less at most the ones it hides or replaces).
struct Outcome {
  double iou = 0.0, recall = 0.0;
  bool same_floor = false;
};

/// Inserts `model` at `count` seeded placements (each cutting at least `min_beams` beams of
/// both sweeps) into the pair's current sweep, detects with the defaults, prints a row each
/// and returns each placement's outcome.
std::vector<Outcome> runInsertions(const Pair& pair, const sim::ObjectModel& model,
                                   const char* name, int count, std::uint64_t seed,
                                   std::size_t min_beams = 40) {
  const auto placements = sim::freeFloorPlacements(pair.current, pair.currentOrigin(),
                                                   pair.reference, model, count, seed, min_beams);
  Params p;
  p.superquadric.enabled = false;
  Pipeline pipeline(p);
  pipeline.setReference(pair.reference);
  const Result unchanged = pipeline.detect(pair.current);
  std::vector<Outcome> outcomes;
  for (const sim::Placement& where : placements) {
    const sim::Insertion in =
        sim::insertByRayCasting(pair.current, pair.currentOrigin(), model, where);
    const Result r = pipeline.detect(in.cloud);
    const Found f = bestSegment(r, in.truth);
    std::size_t other = 0, found = 0;
    for (std::size_t i = 0; i < r.labels.size(); ++i) {
      other += r.labels[i] != 0 && in.truth[i] == 0;
      found += r.labels[i] != 0 && in.truth[i] != 0;
    }
    Outcome o;
    o.iou = f.iou;
    o.recall = f.truth_points ? static_cast<double>(found) / f.truth_points : 0.0;
    o.same_floor = r.floor_found == unchanged.floor_found;
    if (o.same_floor && r.floor_found) {
      const double lost = static_cast<double>(groundPoints(unchanged)) - groundPoints(r);
      o.same_floor = std::abs(r.floor[3] - unchanged.floor[3]) < 0.01 &&
                     r.floor.head<3>().dot(unchanged.floor.head<3>()) > std::cos(M_PI / 180.0) &&
                     lost <= 0.02 * groundPoints(unchanged) + in.replaced;
    }
    std::printf("| %s + %s | (%.2f, %.2f), %.1f m from the sensor | %zu | %.3f | %zu | %zu |\n",
                name, model.name.c_str(), where.base.x(), where.base.y(),
                std::hypot(where.base.x() - pair.currentOrigin().x(),
                           where.base.y() - pair.currentOrigin().y()),
                in.replaced, f.iou, f.segments, other);
    std::printf("  floor %s, %zu ground points (%s, %zu without the object); recall %.3f\n",
                r.floor_found ? "found" : "none", groundPoints(r),
                o.same_floor ? "same floor" : "FLOOR MOVED", groundPoints(unchanged), o.recall);
    outcomes.push_back(o);
  }
  return outcomes;
}

}  // namespace

TEST(SemiReal, PersonIsCutFromTheCorridorFrame) {
  const fs::path path = dataDir() / "pcl_test_indoor_scenes" / "five_people.pcd";
  REQUIRE_DATA(path);
  const sim::ObjectModel person = realPerson();
  std::printf("person: %zu points, %.2f m tall, radius %.2f m\n", person.points.size(),
              person.height, person.radius);
  EXPECT_GT(person.height, 1.4);
  EXPECT_LT(person.height, 2.0);
  EXPECT_LT(person.radius, 0.6);
  EXPECT_GT(person.points.size(), 1000u);
}

// The ETH apartment pair (tilting laser): its free floor is a strip 1-5 m ahead of the
// sensor, where a person cuts 40-100 beams and a box 70-170.
TEST(SemiReal, EthBoxIsFoundAtEachPlacement) {
  REQUIRE_DATA(ethDir() / "cloud_1.pcd");
  const std::vector<Outcome> found =
      runInsertions(ethPair(), sim::boxModel({0.5, 0.4, 0.6}), "eth", 3, 2);
  ASSERT_EQ(found.size(), 3u);
  // Measured: IoU 0.792, 0.722, 0.847.
  for (const Outcome& o : found) EXPECT_GE(o.iou, 0.7);
  for (const Outcome& o : found) EXPECT_TRUE(o.same_floor);
}

TEST(SemiReal, EthPersonIsFoundAtEachPlacement) {
  REQUIRE_DATA(ethDir() / "cloud_1.pcd");
  REQUIRE_DATA(dataDir() / "pcl_test_indoor_scenes" / "five_people.pcd");
  // The free floor of this sweep is a corridor running away from the sensor: a person there
  // stands 3-6 m out and cuts 29-100 beams of the tilting laser (tilt lines about 10 cm
  // apart at 5 m), so the placements ask for 25 beams rather than 40.
  const std::vector<Outcome> found = runInsertions(ethPair(), realPerson(), "eth", 3, 1, 25);
  ASSERT_EQ(found.size(), 3u);
  // Measured: IoU 0.909 (4.2 m), 0.867 (2.6 m), 1.000 (5.2 m).
  for (const Outcome& o : found) EXPECT_GE(o.iou, 0.7);
  for (const Outcome& o : found) EXPECT_TRUE(o.same_floor);
}

// The room pair (a 2D laser panned about the vertical, every point stored twice): its floor
// is seen 1-6 m around the sensor, a person cuts 100-300 beams and a box 150-400.
TEST(SemiReal, RoomBoxIsFoundAtEachPlacement) {
  REQUIRE_DATA(roomDir() / "room_scan2.pcd");
  const std::vector<Outcome> found =
      runInsertions(roomPair(), sim::boxModel({0.5, 0.4, 0.6}), "room", 3, 2);
  ASSERT_EQ(found.size(), 3u);
  // Measured: IoU 0.989, 0.977, 0.789; the floor found and unmoved each time.
  for (const Outcome& o : found) EXPECT_GE(o.iou, 0.7);
  for (const Outcome& o : found) EXPECT_TRUE(o.same_floor);
}

TEST(SemiReal, RoomPersonIsFoundAtEachPlacement) {
  REQUIRE_DATA(roomDir() / "room_scan2.pcd");
  REQUIRE_DATA(dataDir() / "pcl_test_indoor_scenes" / "five_people.pcd");
  const std::vector<Outcome> found = runInsertions(roomPair(), realPerson(), "room", 3, 1);
  ASSERT_EQ(found.size(), 3u);
  // Measured: IoU 1.000, 1.000, 0.980 at 4.1, 1.6 and 2.5 m. Stray differences on the wall and
  // ceiling stacked above the far person stay apart: the sweep saw through the gap between them.
  for (const Outcome& o : found) EXPECT_GE(o.iou, 0.7);
  for (const Outcome& o : found) EXPECT_GE(o.recall, 0.95);
  for (const Outcome& o : found) EXPECT_TRUE(o.same_floor);
}

// A person standing on the floor never moves the floor: a corridor sweep (floor z = 0,
// sensor 0.6 m above it) with and without the real person ray-cast into it gives the same
// floor plane, about as many ground points, and the person, feet included, is found.
TEST(SemiReal, PersonOnTheFloorLeavesTheFloorAlone) {
  REQUIRE_DATA(dataDir() / "pcl_test_indoor_scenes" / "five_people.pcd");
  synthetic::SceneOptions o;
  o.range_sigma_m = 0.005;
  o.objects.clear();
  o.seed = 1;
  Cloud ref = synthetic::makeCorridor(o).cloud;
  o.seed = 2;
  Cloud cur = synthetic::makeCorridor(o).cloud;
  const Eigen::Vector3f at = o.sensor.cast<float>();
  setSensorOrigin(ref, at);
  setSensorOrigin(cur, at);
  const sim::ObjectModel person = realPerson();
  const sim::Placement where{Eigen::Vector3d(3.0, 0.3, 0.0),
                             0.0};  // seen side (-x) toward the sensor
  const sim::Insertion in = sim::insertByRayCasting(cur, at, person, where);
  ASSERT_GT(in.replaced, 150u);
  Params p;
  p.superquadric.enabled = false;
  Pipeline pipeline(p);
  pipeline.setReference(ref);
  auto ground = [](const Result& r) {
    std::map<std::string, std::size_t> c(r.point_counts.begin(), r.point_counts.end());
    return static_cast<double>(c["after_outliers"]) - static_cast<double>(c["after_ground"]);
  };
  const Result without = pipeline.detect(cur);
  const Result with = pipeline.detect(in.cloud);
  ASSERT_TRUE(without.floor_found);
  ASSERT_TRUE(with.floor_found);
  EXPECT_NEAR(with.floor[3], without.floor[3], 0.01);
  EXPECT_GT(with.floor.head<3>().dot(without.floor.head<3>()), std::cos(M_PI / 180.0));
  EXPECT_NEAR(ground(with), ground(without), 0.02 * ground(without));
  const Found f = bestSegment(with, in.truth);
  std::size_t feet = 0, feet_found = 0;
  for (std::size_t i = 0; i < in.truth.size(); ++i)
    if (in.truth[i] && in.cloud[i].z > 0.05f && in.cloud[i].z < 0.5f)
      ++feet, feet_found += with.labels[i] != 0;
  std::printf(
      "person in the corridor: IoU %.3f, %zu of %zu points 0.05-0.5 m above the floor "
      "labelled, ground %.0f / %.0f points\n",
      f.iou, feet_found, feet, ground(with), ground(without));
  EXPECT_GE(f.iou, 0.7);
  EXPECT_GE(feet, 20u);
  EXPECT_GE(feet_found, feet * 7 / 10);
}

// The real person's parts where the room sweep sees it with at least 200 points (1.6 and
// 2.5 m out; 1096 and 494 points), cut where its section steps (standing_parts.h). This
// person's section widens gradually from the legs (0.31-0.35 m) to the chest (0.38-0.48 m),
// no step and the legs never apart, and narrows at the neck (0.15-0.26 m): a body and a head,
// the head a part of its own above 80 % of the person's height and the body upright (the
// part holding most of the points between 55 and 75 % of the height; the trunk spans about
// 47-77 % of a person's height). Split and merge alone gives 2 and 1 parts, the first with
// its part over the trunk 88 deg from up. Printed also for the far placement.
TEST(SemiReal, RoomPersonGetsAnUprightBodyAndAHead) {
  REQUIRE_DATA(roomDir() / "room_scan2.pcd");
  REQUIRE_DATA(dataDir() / "pcl_test_indoor_scenes" / "five_people.pcd");
  const Pair pair = roomPair();
  const sim::ObjectModel person = realPerson();
  const auto placements = sim::freeFloorPlacements(pair.current, pair.currentOrigin(),
                                                   pair.reference, person, 3, 1, 40);
  ASSERT_EQ(placements.size(), 3u);
  for (const bool standing : {true, false}) {
    Params p;
    p.superquadric.standing_parts = standing;
    Pipeline pipeline(p);
    pipeline.setReference(pair.reference);
    for (const sim::Placement& where : placements) {
      const sim::Insertion in =
          sim::insertByRayCasting(pair.current, pair.currentOrigin(), person, where);
      const Result r = pipeline.detect(in.cloud);
      // The person's segment: the one holding most of its points.
      const Segment* best = nullptr;
      std::size_t best_count = 0;
      for (const Segment& s : r.segments) {
        std::size_t n = 0;
        for (int i : s.indices) n += in.truth[static_cast<std::size_t>(i)] != 0;
        if (n > best_count) best = &s, best_count = n;
      }
      ASSERT_NE(best, nullptr);
      const double floor_z = where.base.z(), height = person.height;
      std::vector<const Superquadric*> parts;
      for (const Superquadric& sq : r.superquadrics)
        if (sq.segment == best->id) parts.push_back(&sq);
      const Superquadric* trunk = nullptr;
      std::size_t trunk_count = 0;
      for (const Superquadric* sq : parts) {
        std::size_t n = 0;
        for (int i : sq->indices) {  // into the input cloud
          const double z = in.cloud[static_cast<std::size_t>(i)].z - floor_z;
          n += z >= 0.55 * height && z <= 0.75 * height;
        }
        if (n > trunk_count) trunk = sq, trunk_count = n;
      }
      ASSERT_NE(trunk, nullptr);
      int long_axis = 0;
      trunk->a.maxCoeff(&long_axis);
      const double tilt =
          std::acos(std::min(1.0, std::abs(trunk->rotation().col(long_axis).z()))) * 180.0 / M_PI;
      // A part all of whose points lie above 80 % of the person's height: the head.
      bool head = false;
      for (const Superquadric* sq : parts) {
        bool above = !sq->indices.empty();
        for (int i : sq->indices)
          above = above && in.cloud[static_cast<std::size_t>(i)].z - floor_z > 0.8 * height;
        head = head || above;
      }
      std::printf(
          "  %s: person of %zu points %.1f m out: %zu parts%s, trunk a (%.2f %.2f %.2f) "
          "tilt %.0f deg\n",
          standing ? "standing parts" : "split and merge alone", in.replaced,
          std::hypot(where.base.x() - pair.currentOrigin().x(),
                     where.base.y() - pair.currentOrigin().y()),
          parts.size(), head ? " (a head)" : "", trunk->a.x(), trunk->a.y(), trunk->a.z(), tilt);
      if (standing && in.replaced >= 200) {
        EXPECT_GE(parts.size(), 2u);
        EXPECT_LE(parts.size(), 7u);
        EXPECT_TRUE(head);
        EXPECT_LE(tilt, 20.0);
      }
    }
  }
}
