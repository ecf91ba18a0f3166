// Shape error of fitted superquadrics against the true points of found objects.
#include <gtest/gtest.h>

#include <fstream>

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
}  // namespace

TEST(ShapeEvaluation, ExactShapeScoresZeroAndALargerOneItsOffset) {
  Cloud cloud;
  std::vector<int> truth;
  makeScene(cloud, truth);
  std::vector<int> predicted(truth.size(), 0);
  for (std::size_t i = 0; i < truth.size(); ++i) predicted[i] = truth[i] == 1 ? 3 : 0;
  const SceneScore score = scoreLabels(predicted, truth);
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
