// The patrol-route simulator and its evaluation: ground truth by construction, and the
// detector against a route map on one seeded scene with known answers.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <unistd.h>
#include <algorithm>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "novelty_detection/eval/route_evaluation.h"
#include "novelty_detection/sim/route.h"

using namespace novelty_detection;

namespace {

int countOf(const std::vector<int>& v, int id) {
  return static_cast<int>(std::count(v.begin(), v.end(), id));
}

}  // namespace

TEST(SimRoute, RouteAndSequenceHoldWhatTheConfigSays) {
  sim::RouteConfig c;
  c.seed = 7;
  c.reference_sweeps = 6;
  c.sequence_sweeps = 4;
  const sim::RouteScene s = sim::generateRoute(c);
  ASSERT_EQ(s.reference.size(), 6u);
  ASSERT_EQ(s.sequence.size(), 4u);
  for (const auto& r : s.reference) {
    EXPECT_EQ(r.labels.size(), r.cloud.size());
    EXPECT_EQ(std::count_if(r.labels.begin(), r.labels.end(), [](int l) { return l != 0; }), 0);
    EXPECT_TRUE(
        r.cloud.sensor_origin_.head<3>().isApprox(r.T_world_sensor.translation().cast<float>()));
  }
  // The route poses look both ways along it.
  EXPECT_LT(s.reference[0].T_world_sensor.linear().col(0).dot(
                s.reference[1].T_world_sensor.linear().col(0)),
            0.0);
  // The object is there in every current sweep, the first with enough points.
  EXPECT_GE(countOf(s.sequence[0].labels, sim::kStayingObjectId), c.min_object_points);
  for (const auto& q : s.sequence) EXPECT_GT(countOf(q.labels, sim::kStayingObjectId), 0);
  // The robot moves current_step_m per sweep; the person walks person_step_m towards it.
  const Eigen::Vector3d step =
      s.sequence[1].T_world_sensor.translation() - s.sequence[0].T_world_sensor.translation();
  EXPECT_NEAR(step.norm(), c.current_step_m, 1e-9);
  ASSERT_GE(s.person_path.size(), 2u);
  EXPECT_NEAR((s.person_path[1] - s.person_path[0]).norm(), c.person_step_m, 1e-9);
  // Merged map: every sweep's points with its viewpoint.
  ReferenceViews views;
  const Cloud map = sim::mergedReference(s, &views);
  std::size_t total = 0;
  for (const auto& r : s.reference) total += r.cloud.size();
  EXPECT_EQ(map.size(), total);
  ASSERT_EQ(views.origins.size(), 6u);
  EXPECT_EQ(views.sweep.size(), total);
  EXPECT_EQ(views.sweep.back(), 5u);
  const Cloud one = sim::mergedReference(s, nullptr, s.nearest_reference);
  EXPECT_EQ(one.size(), s.reference[s.nearest_reference].cloud.size());
  // Deterministic.
  const sim::RouteScene again = sim::generateRoute(c);
  EXPECT_EQ(again.sequence[2].cloud.size(), s.sequence[2].cloud.size());
  EXPECT_FLOAT_EQ(again.sequence[2].cloud[100].x, s.sequence[2].cloud[100].x);
  c.reference_sweeps = 1;
  EXPECT_THROW(sim::generateRoute(c), std::invalid_argument);
}

// Against the route map every sweep is right and the changes over time come out as they
// should: the object confirmed, the person never.
TEST(RouteEvaluation, ObjectConfirmedPersonRejectedOnASeededRoute) {
  const sim::RouteScene s = sim::generateRoute(sim::routeSceneConfig(0, 1));
  const RouteSceneResult r = evaluateRouteScene(s, 0, Params(), BaselineOptions(), true);
  ASSERT_EQ(r.route.sweeps.size(), s.sequence.size());
  ASSERT_EQ(r.single.sweeps.size(), s.sequence.size());
  ASSERT_EQ(r.baseline.sweeps.size(), s.sequence.size());
  double f1 = 0.0;
  for (const SceneScore& sc : r.route.sweeps) {
    EXPECT_TRUE(sc.success);  // every object found (IoU >= 0.5), no false segment
    f1 += sc.f1 / r.route.sweeps.size();
  }
  EXPECT_GE(f1, 0.8);
  EXPECT_TRUE(r.object_confirmed);
  EXPECT_EQ(r.confirmed_on_sweep, 1);
  EXPECT_TRUE(r.person_detected);
  EXPECT_TRUE(r.person_rejected);
  const RouteSummary sum = summarizeRoutes({r});
  EXPECT_EQ(sum.sweeps, static_cast<int>(s.sequence.size()));
  EXPECT_DOUBLE_EQ(sum.success_rate, 1.0);
  EXPECT_DOUBLE_EQ(sum.confirmed_rate, 1.0);
  const std::string json = routeSummaryJson(sum);
  for (const char* key : {"success_rate", "mean_f1", "confirmed_rate", "transient_rejected_rate"})
    EXPECT_NE(json.find(key), std::string::npos) << key;
}

// The command-line tool: progress on stderr, one JSON object as the last line of stdout; bad
// arguments exit 2.
TEST(RouteEvaluation, ToolPrintsTheSummaryAsItsLastLine) {
  const std::string bin = std::string(NOVELTY_BIN_DIR) + "/evaluate_route";
  const std::filesystem::path out =
      std::filesystem::temp_directory_path() / ("route_tool_" + std::to_string(::getpid()));
  std::filesystem::create_directories(out);
  const int rc = std::system((bin + " --scenes 1 --seed 1 --no-comparisons --markdown " +
                              (out / "t.md").string() + " > " + (out / "stdout").string() + " 2> " +
                              (out / "stderr").string())
                                 .c_str());
  ASSERT_TRUE(WIFEXITED(rc) && WEXITSTATUS(rc) == 0);
  std::ifstream f(out / "stdout");
  std::string line, last;
  while (std::getline(f, line))
    if (!line.empty()) last = line;
  const auto j = nlohmann::json::parse(last);
  EXPECT_EQ(j["scenes"].get<int>(), 1);
  EXPECT_EQ(j["sweeps"].get<int>(), 5);
  EXPECT_DOUBLE_EQ(j["success_rate"].get<double>(), 1.0);  // as the scene above
  EXPECT_DOUBLE_EQ(j["confirmed_rate"].get<double>(), 1.0);
  EXPECT_DOUBLE_EQ(j["transient_rejected_rate"].get<double>(), 1.0);
  EXPECT_GT(j["median_detect_s"].get<double>(), 0.0);
  std::ifstream err(out / "stderr");
  std::getline(err, line);
  EXPECT_NE(line.find("[1/1]"), std::string::npos) << line;
  EXPECT_TRUE(std::filesystem::file_size(out / "t.md") > 0);
  for (const char* bad : {"--scenes 0", "--scenes x", "--seed -1", "--frobnicate 1", "--scenes"}) {
    const int r = std::system((bin + " " + bad + " > /dev/null 2>&1").c_str());
    EXPECT_TRUE(WIFEXITED(r) && WEXITSTATUS(r) == 2) << bad;
  }
  std::filesystem::remove_all(out);
}
