// simulate_scans and evaluate end to end: files written, consistent, scored.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

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
