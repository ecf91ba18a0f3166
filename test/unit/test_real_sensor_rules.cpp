// Rules for real sensors with known answers: which way is up (preprocess/up), the robot's
// own returns, the novelty distance when much of the scene changed, and stated sensor
// origins (a cloud in its own sensor frame has its origin at zero).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "novelty_detection/alignment/alignment.h"
#include "novelty_detection/pipeline.h"
#include "novelty_detection/preprocess/preprocess.h"
#include "novelty_detection/preprocess/self_returns.h"
#include "novelty_detection/preprocess/up_direction.h"
#include "novelty_detection/segmentation/novelty_segmentation.h"
#include "synthetic_scene.h"

using namespace novelty_detection;

namespace {

double angleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180.0 / M_PI;
}

Cloud rotated(const Cloud& c, const Eigen::Matrix3d& R) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  return transformCloud(c, T);
}

synthetic::Scene corridor(unsigned seed) {
  synthetic::SceneOptions o;
  o.seed = seed;
  o.range_sigma_m = 0.01;
  return synthetic::makeCorridor(o);
}

/// A corridor sweep from `at` (5 mm range noise, `objects` on the floor) with a part of the
/// robot appended: `part()` gives its points; their indices go to `indices`. The sensor origin
/// is stated.
template <class Part>
Cloud sweepWithRobotPart(const Eigen::Vector3d& at, unsigned seed, Part part,
                         std::vector<int>* indices,
                         std::vector<synthetic::AlignedBox> objects = {}) {
  synthetic::SceneOptions o;
  o.seed = seed;
  o.range_sigma_m = 0.005;
  o.sensor = at;
  o.objects = objects;
  synthetic::Scene s = synthetic::makeCorridor(o);
  for (const PointT& q : part()) {
    indices->push_back(static_cast<int>(s.cloud.size()));
    s.cloud.push_back(q);
  }
  setSensorOrigin(s.cloud, at.cast<float>());
  return s.cloud;
}

/// The robot's body: a 0.4 x 0.4 x 0.3 m box below the sensor at `at`, 400 samples on its top.
auto bodyTop(const Eigen::Vector3d& at, unsigned seed) {
  return [at, seed] {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-0.2, 0.2);
    std::vector<PointT> top;
    for (int k = 0; k < 400; ++k)
      top.push_back(PointT(at.x() + u(rng), at.y() + u(rng), at.z() - 0.15));
    return top;
  };
}

/// The reference sweep from (0, 0, 0.6) and the current one from 2 m further along x, each
/// with the robot's body top below its sensor (their indices: body_ref, body_cur); `objects`
/// stand in the current corridor.
struct MovedRobot {
  std::vector<int> body_ref, body_cur;
  Cloud ref, cur;
};
MovedRobot movedRobot(std::vector<synthetic::AlignedBox> objects = {}) {
  const Eigen::Vector3d at_ref(0, 0, 0.6), at_cur(2, 0, 0.6);
  MovedRobot m;
  m.ref = sweepWithRobotPart(at_ref, 1, bodyTop(at_ref, 1), &m.body_ref);
  m.cur = sweepWithRobotPart(at_cur, 2, bodyTop(at_cur, 2), &m.body_cur, std::move(objects));
  return m;
}

/// A new box 0.8 m in front of the current sensor of movedRobot().
const synthetic::AlignedBox kBoxAhead{Eigen::Vector3d(2.8, -0.2, 0.0),
                                      Eigen::Vector3d(3.1, 0.2, 0.5)};

/// How many of the points `indices` the mask marks.
std::size_t markedAmong(const std::vector<std::uint8_t>& mask, const std::vector<int>& indices) {
  std::size_t n = 0;
  for (int i : indices) n += mask[i];
  return n;
}

/// The points of `cloud` strictly inside the box (lo, hi), and how many of them the mask marks.
std::pair<std::size_t, std::size_t> markedInside(const Cloud& cloud,
                                                 const std::vector<std::uint8_t>& mask,
                                                 const Eigen::Vector3f& lo,
                                                 const Eigen::Vector3f& hi) {
  std::size_t inside = 0, marked = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f q = cloud[i].getVector3fMap();
    if ((q.array() > lo.array()).all() && (q.array() < hi.array()).all()) {
      ++inside;
      marked += mask[i];
    }
  }
  return {inside, marked};
}

}  // namespace

TEST(UpDirection, ParsesVectorsAndAutoAndRefusesTheRest) {
  EXPECT_TRUE(parseUp("auto").automatic);
  const UpSetting s = parseUp("0 -2 0");
  EXPECT_FALSE(s.automatic);
  EXPECT_NEAR((s.vector - Eigen::Vector3d(0, -1, 0)).norm(), 0.0, 1e-12);
  for (const char* bad : {"", "0 0", "0 0 0", "1 2 3 4", "up", "nan 0 1", "0 0 inf"})
    EXPECT_THROW(parseUp(bad), std::invalid_argument) << bad;
  Params p;
  p.preprocess.up = "sideways";
  EXPECT_THROW(p.validate(), std::invalid_argument);
}

// A corridor sweep turned by a known rotation: auto finds the floor's normal, which is the
// rotated +z, whatever the rotation (the ceiling and walls are refused: the sensor is not
// above the ceiling, walls are 90 degrees from every nominal up).
TEST(UpDirection, AutoFindsTheFloorOfARotatedSweep) {
  const synthetic::Scene s = corridor(3);
  Cloud c = s.cloud;
  setSensorOrigin(c, Eigen::Vector3f(0, 0, 0.6));
  for (const Eigen::Vector3d& axis : {Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0.3, 1, 0.2)}) {
    for (const double deg : {0.0, 20.0, 40.0}) {
      const Eigen::Matrix3d R(Eigen::AngleAxisd(deg * M_PI / 180, axis.normalized()));
      const UpEstimate e = resolveUp(parseUp("auto"), rotated(c, R));
      EXPECT_EQ(e.source, "plane") << deg;
      EXPECT_LT(angleDeg(e.up, R * Eigen::Vector3d::UnitZ()), 1.0) << deg;
    }
  }
}

// A camera looking down at a floor from 1 m, in the optical frame (x right, y down, z
// forward), organised: up is the floor normal, mostly -y.
TEST(UpDirection, AutoInACameraFrame) {
  Cloud c;
  c.width = 64;
  c.height = 48;
  const Eigen::Matrix3d R_cam_world =  // optical frame: camera pitched 40 deg down
      (Eigen::AngleAxisd(M_PI / 2 + 40 * M_PI / 180, Eigen::Vector3d::UnitX())).toRotationMatrix();
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.002);
  for (int v = 0; v < 48; ++v) {
    for (int u = 0; u < 64; ++u) {
      const Eigen::Vector3d ray_cam((u - 32) / 60.0, (v - 24) / 60.0, 1.0);
      const Eigen::Vector3d ray = R_cam_world.transpose() * ray_cam;  // world, z up
      const double t = ray.z() < -1e-3 ? -1.0 / ray.z() : 3.0;        // floor at z = -1
      Eigen::Vector3d p = R_cam_world * (t * ray);
      p += noise(rng) * p.normalized();
      c.push_back(PointT(p.x(), p.y(), p.z()));
    }
  }
  c.width = 64;
  c.height = 48;
  setSensorOrigin(c, Eigen::Vector3f::Zero());
  const UpEstimate e = resolveUp(parseUp("auto"), c);
  EXPECT_EQ(e.source, "plane");
  EXPECT_LT(angleDeg(e.up, R_cam_world * Eigen::Vector3d::UnitZ()), 1.0);
}

// The pipeline in a rotated frame gives the same labels as in the up frame, and reports
// the floor and up in the input frame.
TEST(UpDirection, RotatedInputGivesTheSameLabels) {
  synthetic::SceneOptions o;
  o.range_sigma_m = 0.01;
  o.seed = 4;
  o.objects = {};
  synthetic::Scene ref = synthetic::makeCorridor(o);
  o.objects = {{Eigen::Vector3d(3.0, -0.3, 0.0), Eigen::Vector3d(3.5, 0.2, 0.6)}};
  o.seed = 5;
  synthetic::Scene cur = synthetic::makeCorridor(o);
  setSensorOrigin(ref.cloud, Eigen::Vector3f(0, 0, 0.6));
  setSensorOrigin(cur.cloud, Eigen::Vector3f(0, 0, 0.6));
  Params p;
  p.superquadric.enabled = false;
  Pipeline a(p);
  a.setReference(ref.cloud);
  const Result ra = a.detect(cur.cloud);
  const Eigen::Matrix3d R(Eigen::AngleAxisd(0.5, Eigen::Vector3d(1, 1, 0).normalized()));
  const Eigen::Vector3d up = R * Eigen::Vector3d::UnitZ();
  Params q = p;
  q.preprocess.up =
      std::to_string(up.x()) + " " + std::to_string(up.y()) + " " + std::to_string(up.z());
  Pipeline b(q);
  b.setReference(rotated(ref.cloud, R));
  const Result rb = b.detect(rotated(cur.cloud, R));
  ASSERT_EQ(ra.segments.size(), 1u);
  ASSERT_EQ(rb.segments.size(), 1u);
  std::size_t differ = 0;
  for (std::size_t i = 0; i < ra.labels.size(); ++i)
    differ += (ra.labels[i] > 0) != (rb.labels[i] > 0);
  EXPECT_LE(differ, ra.segments[0].indices.size() / 50) << "labels differ beyond rounding";
  EXPECT_LT((rb.segments[0].centroid - R * ra.segments[0].centroid).norm(), 0.01);
  ASSERT_TRUE(rb.floor_found);
  EXPECT_LT(angleDeg(rb.floor.head<3>(), up), 0.5);
  EXPECT_LT(angleDeg(rb.up, up), 1e-3);
}

// A robot body (a box around the sensor) seen in both sweeps from poses 2 m apart: its
// returns are marked in both clouds, a new object near the robot is not; from the same pose
// nothing is.
TEST(SelfReturns, BodyMarkedStaticSceneKept) {
  // A new box 0.8 m in front of the current sensor: never a self-return above the floor
  // band (its lowest centimetres, within about one sampling spacing of the floor the robot
  // moved along, match the floor in both frames and are taken like the floor).
  const MovedRobot m = movedRobot({kBoxAhead});
  const Cloud &ref = m.ref, &cur = m.cur;
  PreprocessParams p;
  const SelfReturns s = findSelfReturns(ref, cur, p);
  ASSERT_TRUE(s.checked);
  EXPECT_GE(markedAmong(s.current, m.body_cur), m.body_cur.size() * 95 / 100);
  const auto [box_points, box_marked] = markedInside(
      cur, s.current, Eigen::Vector3f(2.79f, -0.21f, 0.08f), Eigen::Vector3f(3.11f, 0.21f, 0.51f));
  EXPECT_GT(box_points, 100u);
  EXPECT_EQ(box_marked, 0u) << "points of a new object taken for the robot";
  EXPECT_GE(markedAmong(s.reference, m.body_ref), m.body_ref.size() * 95 / 100);
  // Same pose: everything near the sensor matches in the map frame too: nothing marked.
  const SelfReturns same = findSelfReturns(ref, ref, p);
  EXPECT_EQ(same.current_count, 0u);
  EXPECT_EQ(same.reference_count, 0u);
  // Unknown origins: nothing checked.
  Cloud unknown = cur;
  unknown.sensor_origin_.setZero();
  EXPECT_FALSE(findSelfReturns(ref, unknown, p).checked);
}

/// A vertical panel beside a sensor at `at` (sensor frame = map axes): from `hinge` (x, y
/// from the sensor) `length` m along the heading `heading` [rad], 0.2-1.4 m above the floor,
/// sampled every 2 cm.
std::vector<PointT> panel(const Eigen::Vector3d& at, const Eigen::Vector2d& hinge, double heading,
                          double length) {
  std::vector<PointT> out;
  for (double s = 0.0; s <= length; s += 0.02) {
    for (double z = 0.2; z <= 1.4; z += 0.02) {
      out.push_back(PointT(at.x() + hinge.x() + s * std::cos(heading),
                           at.y() + hinge.y() + s * std::sin(heading), z));
    }
  }
  return out;
}

/// Appends `points` to `cloud` (kept unorganised) and returns their indices.
std::vector<int> append(Cloud* cloud, const std::vector<PointT>& points) {
  std::vector<int> indices;
  for (const PointT& q : points) {
    indices.push_back(static_cast<int>(cloud->size()));
    cloud->push_back(q);
  }
  cloud->width = cloud->size(), cloud->height = 1;
  return indices;
}

// A changed surface beside the robot that, in the sensor's frame, lies where the other
// sweep had a surface (a door leaf swung by about the robot's own step and turn) matches
// there along a strip; it runs on past the strip, out of the robot's range, as novel
// structure, so it is no part of the robot: none of it is marked, in either sweep, while
// the robot's body still is.
TEST(SelfReturns, ChangedSurfaceCrossingTheRobotsFrameIsNotTheRobot) {
  const Eigen::Vector3d at_ref(0, 0, 0.6), at_cur(2, 0, 0.6);
  const Eigen::Vector2d hinge(0.4, 0.3);
  MovedRobot m = movedRobot();
  // In its sensor's frame the reference's panel runs straight ahead from the hinge, the
  // current one turned 35 degrees from it: they cross along the hinge; the current panel's
  // far edge lies 1.45-1.6 m from its sensor, at and past self_max_range_m (1.5 m).
  const double turned = 35.0 * M_PI / 180.0;
  const std::vector<int> panel_ref = append(&m.ref, panel(at_ref, hinge, 0.0, 0.9));
  const std::vector<int> panel_cur = append(&m.cur, panel(at_cur, hinge, turned, 0.9));
  PreprocessParams p;
  const SelfReturns s = findSelfReturns(m.ref, m.cur, p, 0.05);
  ASSERT_TRUE(s.sought);
  EXPECT_EQ(markedAmong(s.current, panel_cur), 0u) << "a changed surface taken for the robot";
  EXPECT_EQ(markedAmong(s.reference, panel_ref), 0u) << "a changed surface taken for the robot";
  EXPECT_GE(markedAmong(s.current, m.body_cur), m.body_cur.size() * 95 / 100);
  EXPECT_GE(markedAmong(s.reference, m.body_ref), m.body_ref.size() * 95 / 100);
  // The strip where the two cross is what matches: a panel cut short of the robot's range
  // (0.5 m long, all of it within 1.3 m of the sensor) could be a part of the robot, and
  // its strip is marked.
  MovedRobot short_panel = movedRobot();
  append(&short_panel.ref, panel(at_ref, hinge, 0.0, 0.5));
  const std::vector<int> strip_cur = append(&short_panel.cur, panel(at_cur, hinge, turned, 0.5));
  const SelfReturns cut = findSelfReturns(short_panel.ref, short_panel.cur, p, 0.05);
  EXPECT_GT(markedAmong(cut.current, strip_cur), 50u);
  EXPECT_LT(markedAmong(cut.current, strip_cur), strip_cur.size() / 2);
}

// A sweep whose robot returns were found is pre-processed again without them: its stage
// times list those stages twice, and their totals count both runs.
TEST(SelfReturns, SweepIsSimplifiedAgainWithoutThemAndBothRunsAreTimed) {
  const MovedRobot m = movedRobot();
  const Cloud &ref = m.ref, &cur = m.cur;
  Params p;
  p.superquadric.enabled = false;
  Pipeline pipeline(p);
  pipeline.setReference(ref);
  const Result r = pipeline.detect(cur);
  std::size_t self_returns = 0;
  for (const auto& [stage, n] : r.point_counts)
    if (stage == "self_returns") self_returns = n;
  EXPECT_GE(self_returns, m.body_cur.size() * 95 / 100);
  for (int i : m.body_cur) EXPECT_EQ(r.labels[i], 0) << "robot return " << i << " labelled";
  std::map<std::string, int> runs;
  std::map<std::string, double> sum;
  for (const StageTiming& t : r.timings) ++runs[t.stage], sum[t.stage] += t.ms;
  for (const char* stage : {"preprocess", "multiscale", "distances"})
    EXPECT_EQ(runs[stage], 2) << stage;
  const std::vector<StageTiming> totals = stageTotals(r.timings);
  ASSERT_EQ(totals.size(), runs.size());
  std::vector<std::string> order;
  for (const StageTiming& t : r.timings)
    if (std::find(order.begin(), order.end(), t.stage) == order.end()) order.push_back(t.stage);
  for (std::size_t k = 0; k < totals.size(); ++k) {
    EXPECT_EQ(totals[k].stage, order[k]);
    EXPECT_DOUBLE_EQ(totals[k].ms, sum[totals[k].stage]);
  }
  EXPECT_EQ(stageTotals({{"a", 1.0}, {"b", 2.0}, {"a", 0.5}}).front().ms, 1.5);
}

// The map's side made once (as a map's model keeps it) gives the marks a fresh test gives,
// for every sweep that uses it, from several threads at once, and is left aside when the
// parameters it was made with differ or the sweep did not move.
TEST(SelfReturns, PreparedReferenceGivesTheSameMarks) {
  const MovedRobot m = movedRobot();
  const Cloud &ref = m.ref, &cur = m.cur;
  PreprocessParams p;
  p.min_range_m = 0.2;
  const SelfReturnReference prepared(ref, p);
  const SelfReturns fresh = findSelfReturns(ref, cur, p, 0.05);
  ASSERT_TRUE(fresh.sought);
  ASSERT_GT(fresh.current_count, 0u);
  ASSERT_GT(fresh.reference_count, 0u);
  SelfReturns both[2];
  std::thread other([&] { both[1] = findSelfReturns(ref, cur, p, 0.05, {}, {}, 1, &prepared); });
  both[0] = findSelfReturns(ref, cur, p, 0.05, {}, {}, 2, &prepared);
  other.join();
  for (const SelfReturns& s : both) {
    EXPECT_EQ(s.current, fresh.current);
    EXPECT_EQ(s.reference, fresh.reference);
    EXPECT_EQ(s.tolerance_m, fresh.tolerance_m);
  }
  // Another range than the prepared side's: made afresh, as without it.
  PreprocessParams wider = p;
  wider.self_max_range_m = 3.0;
  const SelfReturns w = findSelfReturns(ref, cur, wider, 0.05, {}, {}, 1, &prepared);
  const SelfReturns w_fresh = findSelfReturns(ref, cur, wider, 0.05);
  EXPECT_EQ(w.current, w_fresh.current);
  EXPECT_EQ(w.reference, w_fresh.reference);
  // A sweep from the same pose: nothing sought, the range and body marks only.
  const SelfReturns still = findSelfReturns(ref, ref, p, 0.05, {}, {}, 1, &prepared);
  EXPECT_FALSE(still.sought);
  EXPECT_EQ(still.reference, findSelfReturns(ref, ref, p, 0.05).reference);
  // Nothing to prepare without an origin or with the filter off.
  Cloud unknown = ref;
  unknown.sensor_origin_.setZero();
  EXPECT_EQ(SelfReturnReference(unknown, p).impl(), nullptr);
  PreprocessParams off = p;
  off.self_filter = false;
  EXPECT_EQ(SelfReturnReference(ref, off).impl(), nullptr);
}

// The map-frame distances may come from an index the caller keeps over every finite
// reference point (repeats included, as a reference model has it): the marks are the same
// as with the index built over the distinct points.
TEST(SelfReturns, KeptReferenceIndexGivesTheSameMarks) {
  MovedRobot m = movedRobot({kBoxAhead});
  Cloud& ref = m.ref;
  const Cloud& cur = m.cur;
  // Every tenth reference point repeated, one missing.
  for (std::size_t i = 0, n = ref.size(); i < n; i += 10) ref.push_back(ref[i]);
  ref.push_back(PointT(NAN, NAN, NAN));
  ref.width = ref.size(), ref.height = 1;
  NearestNeighbourIndex index;
  index.build(ref, finiteIndices(ref));
  PreprocessParams p;
  const SelfReturns built = findSelfReturns(ref, cur, p, 0.05);
  const SelfReturns kept =
      findSelfReturns(ref, cur, p, 0.05,
                      [&index](const Eigen::Vector3f& q, double r) { return index.within(q, r); });
  ASSERT_TRUE(kept.checked);
  EXPECT_GE(markedAmong(kept.current, m.body_cur), m.body_cur.size() * 95 / 100);
  EXPECT_EQ(kept.current, built.current);
  EXPECT_EQ(kept.reference, built.reference);
  EXPECT_EQ(kept.current_count, built.current_count);
  // On three threads: the same marks.
  const SelfReturns threaded = findSelfReturns(ref, cur, p, 0.05, {}, {}, 3);
  EXPECT_EQ(threaded.current, built.current);
  EXPECT_EQ(threaded.reference, built.reference);
  // The current sweep's index from pre-processing (its distinct finite points, here with
  // repeats and a missing point in the sweep) serves the other direction: the same marks.
  Cloud cur_repeated = cur;
  for (std::size_t i = 0, n = cur.size(); i < n; i += 7) cur_repeated.push_back(cur[i]);
  cur_repeated.push_back(PointT(NAN, NAN, NAN));
  cur_repeated.width = cur_repeated.size(), cur_repeated.height = 1;
  cur_repeated.sensor_origin_ = cur.sensor_origin_;
  cur_repeated.sensor_orientation_ = cur.sensor_orientation_;
  const PreprocessResult pre = Preprocessor(p).compute(cur_repeated);
  ASSERT_TRUE(pre.distinct_index);
  EXPECT_EQ(pre.distinct_index->size(), pre.finite.size() - pre.duplicates.size());
  const SelfReturns plain = findSelfReturns(ref, cur_repeated, p, 0.05);
  const SelfReturns both = findSelfReturns(
      ref, cur_repeated, p, 0.05,
      [&index](const Eigen::Vector3f& q, double r) { return index.within(q, r); },
      [&pre](const Eigen::Vector3f& q, double r) { return pre.distinct_index->within(q, r); });
  EXPECT_GE(markedAmong(both.reference, m.body_ref), m.body_ref.size() * 95 / 100);
  EXPECT_EQ(both.current, plain.current);
  EXPECT_EQ(both.reference, plain.reference);
}

// A cloud stored twice (every return repeated, as some recorded scans are) is the same
// sweep: the tolerance is measured between distinct samples (not the zero gap between a
// point and its copy), and both copies of each point get the same mark as the single sweep.
TEST(SelfReturns, RepeatedPointsChangeNothing) {
  auto twice = [](const Cloud& c) {
    Cloud d = c;
    d.insert(d.end(), c.begin(), c.end());
    d.width = d.size(), d.height = 1;
    return d;
  };
  const MovedRobot m = movedRobot();
  const Cloud &ref = m.ref, &cur = m.cur;
  PreprocessParams p;
  const SelfReturns once = findSelfReturns(ref, cur, p);
  const SelfReturns doubled = findSelfReturns(twice(ref), twice(cur), p);
  ASSERT_TRUE(doubled.checked);
  EXPECT_GT(once.tolerance_m, 0.0);
  EXPECT_DOUBLE_EQ(doubled.tolerance_m, once.tolerance_m);
  ASSERT_EQ(doubled.current.size(), 2 * cur.size());
  for (std::size_t i = 0; i < cur.size(); ++i) {
    ASSERT_EQ(doubled.current[i], once.current[i]) << i;
    ASSERT_EQ(doubled.current[i + cur.size()], once.current[i]) << i;
  }
  for (std::size_t i = 0; i < ref.size(); ++i) {
    ASSERT_EQ(doubled.reference[i], once.reference[i]) << i;
    ASSERT_EQ(doubled.reference[i + ref.size()], once.reference[i]) << i;
  }
  EXPECT_GE(markedAmong(doubled.current, m.body_cur), m.body_cur.size() * 95 / 100);
  EXPECT_EQ(doubled.current_count, 2 * once.current_count);
}

// A sparsely sampled part of the robot (a slanted bracket beside the sensor, 30 returns on
// other beams in each sweep, as a tilting laser or a sub-sampled cloud gives it) lies farther
// from the other sweep's samples of it than the dense scene's spacing: its own spacing sets
// its tolerance, and all of it is the robot. A new box 0.8 m ahead stays a change.
TEST(SelfReturns, SparseBodyPartMatchesByItsOwnSpacing) {
  // The bracket: a 0.5 x 0.4 m plate tilted 45 degrees, 0.25 m to the sensor's left,
  // 30 returns (about 8 cm apart, twice the scene's own spacing near the sensor).
  auto bracket = [](const Eigen::Vector3d& at, unsigned seed) {
    return [at, seed] {
      std::mt19937 rng(seed + 100);
      std::uniform_real_distribution<double> u(0.0, 1.0);
      std::vector<PointT> plate;
      for (int k = 0; k < 30; ++k) {
        const double a = u(rng), b = u(rng);
        plate.push_back(
            PointT(at.x() - 0.25 + 0.5 * a, at.y() + 0.25 + 0.28 * b, at.z() - 0.05 - 0.28 * b));
      }
      return plate;
    };
  };
  const Eigen::Vector3d at_ref(0, 0, 0.6), at_cur(1.5, 0, 0.6);
  std::vector<int> part_ref, part_cur;
  const Cloud ref = sweepWithRobotPart(at_ref, 1, bracket(at_ref, 1), &part_ref);
  const Cloud cur =
      sweepWithRobotPart(at_cur, 2, bracket(at_cur, 2), &part_cur,
                         {{Eigen::Vector3d(2.3, -0.2, 0.0), Eigen::Vector3d(2.6, 0.2, 0.5)}});
  PreprocessParams p;
  const SelfReturns s = findSelfReturns(ref, cur, p);
  ASSERT_TRUE(s.checked);
  const std::size_t marked = markedAmong(s.current, part_cur);
  const std::size_t marked_ref = markedAmong(s.reference, part_ref);
  const auto [box_points, box_marked] = markedInside(
      cur, s.current, Eigen::Vector3f(2.29f, -0.21f, 0.06f), Eigen::Vector3f(2.61f, 0.21f, 0.51f));
  std::printf(
      "bracket: %zu of %zu current, %zu of %zu reference points marked; tolerance %.4f m; "
      "box %zu of %zu\n",
      marked, part_cur.size(), marked_ref, part_ref.size(), s.tolerance_m, box_marked, box_points);
  EXPECT_GE(marked, part_cur.size() * 95 / 100);
  EXPECT_GE(marked_ref, part_ref.size() * 95 / 100);
  EXPECT_GT(box_points, 100u);
  EXPECT_EQ(box_marked, 0u) << "points of a new object taken for the robot";
  // The plain tolerance alone leaves most of the bracket (the case this rule is for).
  std::size_t within_plain = 0;
  for (std::size_t k = 0; k < part_cur.size(); ++k) {
    float best = std::numeric_limits<float>::infinity();
    for (int j : part_ref)
      best = std::min(best, ((ref[j].getVector3fMap() - at_ref.cast<float>()) -
                             (cur[part_cur[k]].getVector3fMap() - at_cur.cast<float>()))
                                .norm());
    within_plain += best <= s.tolerance_m;
  }
  EXPECT_LT(within_plain, part_cur.size() / 2);
}

// A configured body box catches a body part the sweep-to-sweep rule cannot: one that moved
// with the robot's own mechanism (a mast seen at a different place relative to the sensor in
// each sweep), and the body when the robot did not move at all.
TEST(SelfReturns, BodyBoxIsTheRobotInBothSweeps) {
  synthetic::SceneOptions o;
  o.seed = 4;
  o.range_sigma_m = 0.005;
  o.objects.clear();
  const Eigen::Vector3f at = o.sensor.cast<float>();
  Cloud ref = synthetic::makeCorridor(o).cloud;
  o.seed = 5;
  Cloud cur = synthetic::makeCorridor(o).cloud;
  // A mast part 0.3 m behind the sensor, 0.1 m apart in the two sweeps.
  std::vector<int> mast_ref, mast_cur;
  for (int k = 0; k < 200; ++k) {
    const float z = at.z() - 0.4f + 0.002f * k;
    mast_ref.push_back(static_cast<int>(ref.size()));
    ref.push_back(PointT(at.x() - 0.3f, at.y() - 0.05f, z));
    mast_cur.push_back(static_cast<int>(cur.size()));
    cur.push_back(PointT(at.x() - 0.3f, at.y() + 0.05f, z));
  }
  setSensorOrigin(ref, at);
  setSensorOrigin(cur, at);
  PreprocessParams p;
  const SelfReturns without = findSelfReturns(ref, cur, p, 0.05);
  EXPECT_EQ(markedAmong(without.current, mast_cur), 0u);  // the robot did not move: not sought
  p.body_box = "-0.4 -0.15 -0.5 -0.2 0.15 0.1";           // in the sensor's frame
  const SelfReturns with = findSelfReturns(ref, cur, p, 0.05);
  EXPECT_EQ(markedAmong(with.current, mast_cur), mast_cur.size());
  EXPECT_EQ(markedAmong(with.reference, mast_ref), mast_ref.size());
  // Only the box: the corridor is untouched.
  EXPECT_EQ(with.current_count, mast_cur.size());
  // The box turns with the sensor: a sensor yawed by 180 degrees sees it on the other side.
  Cloud turned = cur;
  turned.sensor_orientation_ =
      Eigen::Quaternionf(Eigen::AngleAxisf(M_PI, Eigen::Vector3f::UnitZ()));
  EXPECT_EQ(markedAmong(findSelfReturns(ref, turned, p, 0.05).current, mast_cur), 0u);
  for (const char* bad : {"1 2 3", "0 0 0 -1 1 1", "0 0 0 1 1 nan", "a b c d e f"}) {
    p.body_box = bad;
    EXPECT_THROW(p.validate(), std::invalid_argument) << bad;
  }
  p.body_box = "";
  EXPECT_NO_THROW(p.validate());
}

// A tilting laser's head pitches within every sweep: a sweep whose sensor orientation is
// the head's at its stamp has not moved the robot, and its returns are not sought (seeking
// them would take a second pass over the sweep). A turn about up is a move.
TEST(SelfReturns, ATiltingHeadIsNotAMove) {
  const auto q = [](double angle, const Eigen::Vector3f& axis) {
    return Eigen::Quaternionf(Eigen::AngleAxisf(static_cast<float>(angle), axis));
  };
  const Eigen::Quaternionf level = q(0.3, Eigen::Vector3f::UnitZ());
  const Eigen::Vector3f y = Eigen::Vector3f::UnitY(), x = Eigen::Vector3f::UnitX();
  EXPECT_NEAR(headingChange(level, level * q(0.5, y)), 0.0, 1e-6);   // pitched
  EXPECT_NEAR(headingChange(level, level * q(-0.4, x)), 0.0, 1e-6);  // rolled
  EXPECT_NEAR(headingChange(level, q(M_PI / 2, Eigen::Vector3f::UnitZ()) * level * q(0.5, y)),
              M_PI / 2, 1e-5);  // turned a quarter and pitched
  EXPECT_NEAR(headingChange(level, q(-3.0, Eigen::Vector3f::UnitZ()) * level), 3.0, 1e-5);

  const Eigen::Vector3d at(0, 0, 0.6);
  std::vector<int> body;
  const Cloud ref = sweepWithRobotPart(at, 1, bodyTop(at, 1), &body);
  ASSERT_TRUE(findSelfReturns(ref, ref, PreprocessParams(), 0.05).checked);
  Cloud pitched = ref;
  pitched.sensor_orientation_ = ref.sensor_orientation_ * q(0.6, y);
  const SelfReturns tilt = findSelfReturns(ref, pitched, PreprocessParams(), 0.05);
  EXPECT_TRUE(tilt.checked);
  EXPECT_FALSE(tilt.sought);
  Cloud turned = ref;
  turned.sensor_orientation_ = q(0.5, Eigen::Vector3f::UnitZ()) * ref.sensor_orientation_;
  EXPECT_TRUE(findSelfReturns(ref, turned, PreprocessParams(), 0.05).sought);
}

// Half the points moved: tau stays at the noise scale of the half that matches.
TEST(NoveltyDistance, HoldsWhenMuchOfTheSceneChanged) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.005);
  std::uniform_real_distribution<double> moved(0.1, 0.5);
  std::vector<double> matched, mixed;
  for (int i = 0; i < 4000; ++i) matched.push_back(std::abs(noise(rng)) + 0.01);
  mixed = matched;
  for (int i = 0; i < 3000; ++i) mixed.push_back(moved(rng));
  const double clean = noveltyDistanceThreshold(matched, 6.0, 0.0);
  const double contaminated = noveltyDistanceThreshold(mixed, 6.0, 0.0);
  EXPECT_GT(clean, 0.02);
  EXPECT_LT(clean, 0.06);
  EXPECT_NEAR(contaminated, clean, 0.2 * clean);
  EXPECT_LT(contaminated, 0.1);  // below the moved points
  EXPECT_DOUBLE_EQ(noveltyDistanceThreshold({}, 6.0, 0.03), 0.03);
}

// A pair sampled at the same pixels (the current sweep is the reference, point for point):
// the distances to the map are all zero, so the data alone would give tau = 0 and any
// re-sampled return would be "novel". The sensor's noise, measured on the sweep's own planes,
// floors it at noise_floor_factor sigma. The simulated range noise is 1 cm along the beam;
// the thickness normal to the walls and floor, seen at an angle, is less.
TEST(NoveltyDistance, FlooredByTheSensorNoiseOnAPixelIdenticalPair) {
  synthetic::SceneOptions opt;
  opt.range_sigma_m = 0.01;
  opt.seed = 11;
  Cloud cloud = synthetic::makeCorridor(opt).cloud;
  setSensorOrigin(cloud, opt.sensor.cast<float>());
  Cloud current = cloud;
  // A few returns drawn again (as a depth camera's edge pixels flicker): 2 % of the points
  // move by up to 4 sigma along their beam.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const Eigen::Vector3f o = opt.sensor.cast<float>();
  for (PointT& p : current.points) {
    if (u(rng) > 0.02) continue;
    const Eigen::Vector3f ray = (p.getVector3fMap() - o).normalized();
    p.getVector3fMap() += static_cast<float>(0.04 * (2.0 * u(rng) - 1.0)) * ray;
  }
  auto run = [&](double factor) {
    Params p;
    p.superquadric.enabled = false;
    p.segmentation.noise_floor_factor = factor;
    Pipeline pipeline(p);
    pipeline.setReference(cloud);
    return pipeline.detect(current);
  };
  const Result floored = run(3.0);
  EXPECT_EQ(floored.noise_model, "constant");
  EXPECT_GT(floored.noise_sigma_m, 0.005);
  EXPECT_LT(floored.noise_sigma_m, 0.0105);
  EXPECT_NEAR(floored.tau_m, 3.0 * floored.noise_sigma_m, 1e-9);
  EXPECT_TRUE(floored.segments.empty());
  // Without the floor the flickering returns make a false segment.
  const Result bare = run(0.0);
  EXPECT_LT(bare.tau_m, 0.002);
  EXPECT_FALSE(bare.segments.empty());
  std::printf("tau %.4f floored, %.4f bare; segments %zu floored, %zu bare\n", floored.tau_m,
              bare.tau_m, floored.segments.size(), bare.segments.size());
}

// A stated zero origin is known; an unstated one is not.
TEST(SensorOrigin, StatedZeroIsKnown) {
  Cloud c;
  EXPECT_FALSE(sensorOriginKnown(c.sensor_origin_));
  setSensorOrigin(c, Eigen::Vector3f::Zero());
  EXPECT_TRUE(sensorOriginKnown(c.sensor_origin_));
  c.sensor_origin_ << 1, 2, 3, 0;
  EXPECT_TRUE(sensorOriginKnown(c.sensor_origin_));
  c.sensor_origin_ << NAN, 2, 3, 1;
  EXPECT_FALSE(sensorOriginKnown(c.sensor_origin_));
}
