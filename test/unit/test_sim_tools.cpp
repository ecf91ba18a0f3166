// simulate_scans and evaluate end to end: files written, consistent, scored.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>

#include "novelty_detection/eval/evaluation.h"
#include "novelty_detection/io/cloud_io.h"

namespace fs = std::filesystem;
using namespace novelty_detection;

namespace {
const std::string kBin = NOVELTY_BIN_DIR;
int run(const std::string& cmd) {
  const int rc = std::system((cmd + " > /dev/null 2>&1").c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}
std::string slurp(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}
}  // namespace

TEST(SimTools, SimulateScansWritesAConsistentSceneAndEvaluateScoresIt) {
  const fs::path out = fs::path(::testing::TempDir()) / "novelty_sim_tools" / "scene";
  fs::remove_all(out);
  ASSERT_EQ(run(kBin + "/simulate_scans --out " + out.string() +
                " --seed 5 --lines 12 --kinds person,door --offset 0.1 0 3"),
            0);
  for (const char* f : {"ref.pcd", "cur.pcd", "gt_labels.txt", "scene.json", "scans.bag"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
  const CloudFile cur = loadCloudFile((out / "cur.pcd").string());
  const std::vector<int> gt = readLabelFile((out / "gt_labels.txt").string());
  ASSERT_EQ(gt.size(), cur.cloud.size());
  EXPECT_GT(cur.cloud.size(), 12u * 1081u * 9 / 10);
  // VIEWPOINT is the current sensor: the reference one moved by the offset (0.1 m ahead).
  const CloudFile ref = loadCloudFile((out / "ref.pcd").string());
  EXPECT_NEAR((cur.T_frame_sensor.translation() - ref.T_frame_sensor.translation()).norm(), 0.1,
              1e-5);
  EXPECT_NE(slurp(out / "scene.json").find("\"type\": \"person\""), std::string::npos);

  // Perfect labels succeed; bad arguments fail with exit code 2.
  EXPECT_EQ(run(kBin + "/evaluate --labels " + (out / "gt_labels.txt").string() + " --gt " +
                (out / "gt_labels.txt").string()),
            0);
  EXPECT_EQ(run(kBin + "/evaluate --labels " + (out / "gt_labels.txt").string()), 2);
  EXPECT_EQ(run(kBin + "/simulate_scans --out " + out.string() + " --lines x"), 2);
  EXPECT_EQ(run(kBin + "/simulate_scans --out " + out.string() + " --layout attic"), 2);
  EXPECT_EQ(run(kBin + "/simulate_scans --out " + out.string() + " --route 1"), 2);
  EXPECT_EQ(run(kBin + "/simulate_scans --out " + out.string() + " --route 5 --suite 3"), 2);
  EXPECT_EQ(run(kBin + "/simulate_scans --out " + out.string() + " --route 5 --kinds box"), 2);
}

TEST(SimTools, SuiteModeWritesScenesAndEvaluateCountsMissingResults) {
  const fs::path root = fs::path(::testing::TempDir()) / "novelty_sim_suite";
  fs::remove_all(root);
  const fs::path suite = root / "suite", results = root / "results";
  ASSERT_EQ(run(kBin + "/simulate_scans --out " + suite.string() +
                " --suite 2 --lines 10 --no-bag --seed 3"),
            0);
  EXPECT_TRUE(fs::exists(suite / "suite.json"));
  EXPECT_TRUE(fs::exists(suite / "scene_001" / "cur.pcd"));
  EXPECT_FALSE(fs::exists(suite / "scene_001" / "scans.bag"));
  fs::create_directories(results / "scene_000");
  fs::copy_file(suite / "scene_000" / "gt_labels.txt", results / "scene_000" / "labels.txt");
  const fs::path csv = root / "table.csv";
  ASSERT_EQ(run(kBin + "/evaluate --suite " + suite.string() + " --results " + results.string() +
                " --csv " + csv.string() + " --markdown " + (root / "t.md").string()),
            0);
  const std::string table = slurp(csv);
  EXPECT_NE(table.find("scene_000,1,"), std::string::npos);
  EXPECT_NE(table.find("scene_001,0,"), std::string::npos);
  EXPECT_NE(table.find("missing labels.txt"), std::string::npos);
  EXPECT_NE(slurp(root / "t.md").find("success rate 50.0 %"), std::string::npos);
}

// The suite's JSON lists each found object's shape figures in its scene (id, kind, points,
// parts, surface error beside the floor, semi-axis error of a single shape fitted with one
// part, else null), and the per-kind means are their means.
TEST(SimTools, EvaluateListsEachFoundObjectsShape) {
  const fs::path root = fs::path(::testing::TempDir()) / "novelty_sim_shapes";
  fs::remove_all(root);
  const fs::path suite = root / "suite", results = root / "results";
  ASSERT_EQ(run(kBin + "/simulate_scans --out " + suite.string() + " --suite 2 --no-bag --seed 4"),
            0);
  for (const char* scene : {"scene_000", "scene_001"}) {
    const fs::path in = suite / scene, out = results / scene;
    ASSERT_EQ(run(kBin + "/novelty_detect --reference " + (in / "ref.pcd").string() +
                  " --current " + (in / "cur.pcd").string() + " --out " + out.string()),
              0)
        << scene;
  }
  const fs::path json = root / "scores.json";
  ASSERT_EQ(run(kBin + "/evaluate --suite " + suite.string() + " --results " + results.string() +
                " --json " + json.string()),
            0);
  const auto scores = nlohmann::json::parse(slurp(json));
  std::map<std::string, std::pair<int, double>> axis;  // per kind: one-part fits, summed error
  int listed = 0;
  for (const auto& scene : scores.at("scenes")) {
    std::map<int, bool> found;
    for (const auto& o : scene.at("objects")) found[o.at("id").get<int>()] = o.at("found");
    for (const auto& e : scene.at("shapes")) {
      ++listed;
      EXPECT_TRUE(found.at(e.at("id").get<int>())) << "only found objects have shapes";
      EXPECT_GE(e.at("parts").get<int>(), 1);
      EXPECT_GT(e.at("points").get<int>(), 0);
      EXPECT_GT(e.at("surface_error_m").get<double>(), 0.0);
      EXPECT_LT(e.at("surface_error_m").get<double>(), 0.5);
      const auto& semi = e.at("semi_axis_error_m");
      const std::string type = e.at("type");
      const bool single = type == "box" || type == "cylinder" || type == "sphere" ||
                          type == "superellipsoid" || type == "door" || type == "moved_object";
      if (!single || e.at("parts").get<int>() != 1) {
        EXPECT_TRUE(semi.is_null()) << type;
      } else {
        ASSERT_TRUE(semi.is_number()) << type;
        EXPECT_GE(semi.get<double>(), 0.0);
        axis[type].first += 1;
        axis[type].second += semi.get<double>();
      }
    }
  }
  EXPECT_GE(listed, 2);
  for (const auto& k : scores.at("summary").at("shapes_by_kind")) {
    const auto it = axis.find(k.at("type").get<std::string>());
    const int n = it == axis.end() ? 0 : it->second.first;
    EXPECT_EQ(k.at("semi_axis_objects").get<int>(), n) << k.at("type");
    if (n > 0) {
      EXPECT_NEAR(k.at("semi_axis_error_m").get<double>(), it->second.second / n, 1e-9)
          << k.at("type");
    }
  }
}
