// cloud_pair.launch as a user runs it: a simulated reference and current cloud published by
// publish_cloud through the detector nodelet, the printed result checked against the scene's
// ground truth; a file that cannot be read ends the launch with publish_cloud's FATAL line.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

#include "process_run.h"

namespace fs = std::filesystem;
using namespace novelty_detection;

namespace {

const fs::path kBin = NOVELTY_BIN_DIR;

using process_run::ProcessRun;
using process_run::run;

std::string roslaunch(const std::string& args) {
  return process_run::roslaunch("cloud_pair.launch", args, 7, 180);
}

class CloudPair : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("novelty_cloud_pair_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    const ProcessRun sim = run((kBin / "simulate_scans").string() + " --out " + dir_.string() +
                               " --seed 1 --novelties 2");
    ASSERT_EQ(sim.code, 0) << sim.out;
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

}  // namespace

TEST_F(CloudPair, RecordedCloudAgainstItsReferenceFindsTheObjects) {
  const ProcessRun r = run(roslaunch("reference_file:=" + (dir_ / "ref.pcd").string() +
                                     " current:=" + (dir_ / "cur.pcd").string() + " print:=true"));
  // The printed result: its novelties and their points.
  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.out, m, std::regex(R"(sweep 1 at [^:]*: (\d+) novelties)")))
      << r.out;
  EXPECT_EQ(std::stoi(m[1]), 2) << r.out;
  std::size_t found = 0;
  const std::regex novelty(R"(novelty \d+: (\d+) points)");
  for (auto it = std::sregex_iterator(r.out.begin(), r.out.end(), novelty);
       it != std::sregex_iterator(); ++it)
    found += std::stoul((*it)[1]);
  std::ifstream in(dir_ / "gt_labels.txt");
  std::size_t truth = 0;
  for (int x; in >> x;) truth += x > 0;
  ASSERT_GT(truth, 100u);
  std::printf("cloud_pair.launch: %zu novel points printed, %zu in the ground truth\n", found,
              truth);
  EXPECT_NEAR(static_cast<double>(found), static_cast<double>(truth), 0.2 * truth);
}

TEST_F(CloudPair, UnreadableCurrentCloudEndsTheLaunchWithItsReason) {
  const ProcessRun r = run(roslaunch("reference_file:=" + (dir_ / "ref.pcd").string() +
                                     " current:=" + (dir_ / "missing.pcd").string()));
  EXPECT_NE(r.out.find("publish_cloud: "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("missing.pcd"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("REQUIRED process [current_cloud"), std::string::npos) << r.out;
  // Without a master, the same refusal at once (exit 1).
  const ProcessRun direct =
      run("ROS_MASTER_URI=http://localhost:1 " + (kBin / "publish_cloud").string() + " " +
          (dir_ / "missing.pcd").string());
  EXPECT_EQ(direct.code, 1) << direct.out;
  EXPECT_NE(direct.out.find("missing.pcd"), std::string::npos) << direct.out;
}
