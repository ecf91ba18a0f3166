// Shape error of fitted superquadrics against the true points of found objects.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>

#include "novelty_detection/eval/shape_evaluation.h"
#include "novelty_detection/shape/superquadric.h"

using namespace novelty_detection;

namespace {
// Object 1: points on a sphere of radius 0.5 at (2, 0, 0.5); the rest: static wall points.
void makeScene(Cloud& cloud, std::vector<int>& truth) {
  Superquadric sphere;
  sphere.a = Eigen::Vector3d::Constant(0.5);
  sphere.position = Eigen::Vector3d(2, 0, 0.5);
  for (const auto& p : sampleSurface(sphere, 400)) {
    cloud.push_back(PointT(p.x(), p.y(), p.z()));
    truth.push_back(1);
  }
  for (int i = 0; i < 400; ++i) {
    cloud.push_back(PointT(5.f, 0.01f * i, 0.f));
    truth.push_back(0);
  }
}
// The label score of a prediction that labels object 1 exactly, as segment 3.
SceneScore foundAsSegmentThree(const std::vector<int>& truth) {
  std::vector<int> predicted(truth.size(), 0);
  for (std::size_t i = 0; i < truth.size(); ++i) predicted[i] = truth[i] == 1 ? 3 : 0;
  return scoreLabels(predicted, truth);
}
}  // namespace

TEST(ShapeEvaluation, ExactShapeScoresZeroAndALargerOneItsOffset) {
  Cloud cloud;
  std::vector<int> truth;
  makeScene(cloud, truth);
  const SceneScore score = foundAsSegmentThree(truth);
  ASSERT_TRUE(score.objects.at(0).found);

  Superquadric fit;
  fit.segment = 3;
  fit.a = Eigen::Vector3d::Constant(0.5);
  fit.position = Eigen::Vector3d(2, 0, 0.5);
  ShapeScore s = scoreShapes(cloud, truth, score, {fit});
  EXPECT_EQ(s.objects, 1);
  EXPECT_NEAR(s.mean_surface_distance_m, 0.0, 1e-6);

  fit.a = Eigen::Vector3d::Constant(0.6);  // every true point 0.1 m inside
  s = scoreShapes(cloud, truth, score, {fit});
  EXPECT_NEAR(s.mean_surface_distance_m, 0.1, 1e-3);

  // Superquadrics of another segment do not count; nor do objects that were not found.
  fit.segment = 7;
  EXPECT_EQ(scoreShapes(cloud, truth, score, {fit}).objects, 0);
  const SceneScore missed = scoreLabels(std::vector<int>(truth.size(), 0), truth);
  EXPECT_EQ(scoreShapes(cloud, truth, missed, {fit}).objects, 0);
}

TEST(ShapeEvaluation, ReadsTheCliContractAndRefusesBadFiles) {
  const std::string path = ::testing::TempDir() + "/novelty_sq.json";
  std::ofstream(path) << R"([{"segment": 2, "a": [0.1, 0.2, 0.3], "epsilon": [0.5, 1.0],
    "position": [1, 2, 3], "orientation": {"quaternion": [0, 0, 0, 1], "euler": [0.1, 0.2, 0.3]},
    "points": 40, "residual": 0.001}])";
  const auto sqs = readSuperquadricsJson(path);
  ASSERT_EQ(sqs.size(), 1u);
  EXPECT_EQ(sqs[0].segment, 2);
  EXPECT_DOUBLE_EQ(sqs[0].a.z(), 0.3);
  EXPECT_DOUBLE_EQ(sqs[0].e1, 0.5);
  EXPECT_DOUBLE_EQ(sqs[0].euler.y(), 0.2);
  EXPECT_EQ(sqs[0].points, 40);
  std::ofstream(path) << R"([{"segment": 2, "a": [0.1, -0.2, 0.3]}])";
  EXPECT_THROW(readSuperquadricsJson(path), std::runtime_error);
  std::ofstream(path) << "not json";
  EXPECT_THROW(readSuperquadricsJson(path), std::runtime_error);
  EXPECT_THROW(readSuperquadricsJson("/nonexistent/sq.json"), std::runtime_error);
}

// Per kind: the fit's error beside the true shape's own floor (0 on exact points, the offset
// of noisy ones), and the semi-axis error of a one-part fit, axes compared by size.
TEST(ShapeEvaluation, PerKindErrorsBesideTheFloorAndSemiAxes) {
  Cloud cloud;
  std::vector<int> truth;
  makeScene(cloud, truth);
  const SceneScore score = foundAsSegmentThree(truth);

  const std::string path = ::testing::TempDir() + "/novelty_scene.json";
  std::ofstream(path) << R"({"objects": [{"id": 1, "type": "sphere", "parts": [
    {"a": [0.5, 0.5, 0.5], "epsilon": [1, 1], "euler": [0, 0, 0], "position": [2, 0, 0.5]}]}]})";
  const std::vector<TrueShape> shapes = readTrueShapes(path);
  ASSERT_EQ(shapes.size(), 1u);
  EXPECT_EQ(shapes[0].type, "sphere");

  // A puck: the right width, half the height; every true point lies on the true sphere.
  Superquadric puck;
  puck.segment = 3;
  puck.a = Eigen::Vector3d(0.5, 0.5, 0.25);
  puck.position = Eigen::Vector3d(2, 0, 0.5);
  auto errors = scoreShapesByObject(cloud, truth, score, {puck}, shapes);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NEAR(errors[0].floor_m, 0.0, 1e-6);
  EXPECT_GT(errors[0].fit_m, 0.05);
  // Sorted axes (0.25, 0.5, 0.5) against (0.5, 0.5, 0.5): mean |difference| 0.25 / 3.
  EXPECT_NEAR(errors[0].semi_axis_error_m, 0.25 / 3, 1e-12);

  EXPECT_EQ(errors[0].parts, 1);
  EXPECT_EQ(errors[0].points,
            static_cast<std::size_t>(std::count(truth.begin(), truth.end(), 1)));  // its points
  // The puck's long axes lie in the horizontal plane: 90 degrees from up.
  EXPECT_NEAR(errors[0].main_part_tilt_deg, 90.0, 1e-6);

  // Two fitted parts: no semi-axis comparison, the surface errors still count. The main
  // body's part is the one nearest most of the true body's points, not the larger: a post
  // 3 m away, tilted by 15 degrees and larger, leaves it to the puck; a tilted egg on the
  // sphere takes it from a puck 3 m away.
  Superquadric post = puck;
  post.position.x() += 3.0;
  post.a = Eigen::Vector3d(0.3, 0.3, 1.2);
  post.euler = Eigen::Vector3d(0.0, 15.0 * M_PI / 180.0, 0.0);
  errors = scoreShapesByObject(cloud, truth, score, {puck, post}, shapes);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_TRUE(std::isnan(errors[0].semi_axis_error_m));
  EXPECT_EQ(errors[0].parts, 2);
  EXPECT_NEAR(errors[0].main_part_tilt_deg, 90.0, 1e-6);
  Superquadric egg = puck, far_puck = puck;
  egg.a = Eigen::Vector3d(0.45, 0.45, 0.55);
  egg.euler = post.euler;
  far_puck.position.x() += 3.0;
  errors = scoreShapesByObject(cloud, truth, score, {far_puck, egg}, shapes);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NEAR(errors[0].main_part_tilt_deg, 15.0, 1e-6);
  const auto two = summarizeShapesByKind(errors);
  ASSERT_EQ(two.size(), 1u);
  EXPECT_DOUBLE_EQ(two[0].parts_mean, 2.0);
  EXPECT_EQ(two[0].parts_3_to_7, 0);
  EXPECT_EQ(two[0].main_part_within_20, 1);

  // Points 2 cm outside the true sphere: the floor is 2 cm, an exact fit's ratio is 1.
  Cloud noisy = cloud;
  for (std::size_t i = 0; i < noisy.size(); ++i) {
    if (truth[i] != 1) continue;
    const Eigen::Vector3f c(2, 0, 0.5);
    const Eigen::Vector3f d = noisy[i].getVector3fMap() - c;
    noisy[i].getVector3fMap() = c + d * (0.52f / d.norm());
  }
  Superquadric exact = puck;
  exact.a = Eigen::Vector3d::Constant(0.5);
  const auto kinds =
      summarizeShapesByKind(scoreShapesByObject(noisy, truth, score, {exact}, shapes));
  ASSERT_EQ(kinds.size(), 1u);
  EXPECT_EQ(kinds[0].objects, 1);
  EXPECT_NEAR(kinds[0].floor_m, 0.02, 1e-3);
  EXPECT_NEAR(kinds[0].ratio(), 1.0, 1e-6);
  EXPECT_EQ(kinds[0].axis_objects, 1);
  EXPECT_NEAR(kinds[0].semi_axis_error_m, 0.0, 1e-12);

  std::ofstream(path) << R"({"objects": [{"id": 1, "type": "box", "parts": [{"a": [0, 1, 1]}]}]})";
  EXPECT_THROW(readTrueShapes(path), std::runtime_error);
  EXPECT_THROW(readTrueShapes(path + ".missing"), std::runtime_error);
}

// Objects seen with at least kWellSeenPoints points are counted apart as well as with the
// rest: the semi-axis error of the well-seen ones, and how many people among them have 3 to 7
// parts.
TEST(ShapeEvaluation, WellSeenObjectsAreReportedApart) {
  auto object = [](const std::string& type, std::size_t points, int parts, double axis) {
    ObjectShapeError e;
    e.type = type;
    e.points = points;
    e.parts = parts;
    e.fit_m = e.floor_m = 0.01;
    e.semi_axis_error_m = axis;
    return e;
  };
  const double none = std::numeric_limits<double>::quiet_NaN();
  const auto kinds = summarizeShapesByKind(
      {object("box", kWellSeenPoints - 1, 1, 0.06), object("box", kWellSeenPoints, 1, 0.02),
       object("box", 900, 2, none), object("person", 80, 4, none), object("person", 300, 2, none),
       object("person", 500, 5, none)});
  ASSERT_EQ(kinds.size(), 2u);
  const KindShapeError& box = kinds[0];
  EXPECT_EQ(box.type, "box");
  EXPECT_EQ(box.axis_objects, 2);
  EXPECT_NEAR(box.semi_axis_error_m, 0.04, 1e-12);
  EXPECT_EQ(box.seen_objects, 2);
  EXPECT_EQ(box.seen_axis_objects, 1);
  EXPECT_NEAR(box.seen_semi_axis_error_m, 0.02, 1e-12);
  const KindShapeError& person = kinds[1];
  EXPECT_EQ(person.parts_3_to_7, 2);
  EXPECT_EQ(person.seen_objects, 2);
  EXPECT_EQ(person.seen_parts_3_to_7, 1);
  EXPECT_EQ(person.seen_axis_objects, 0);
}
