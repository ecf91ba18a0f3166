// The reference workflow end to end, as a user runs it: a simulated bag (tilting laser
// lines, tf and sweeps) played through build_reference.launch, the saved reference
// directory used by novelty_detect, scored against the scene's ground truth; and a save
// that cannot succeed ends the node with a FATAL line.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "novelty_detection/io/cloud_io.h"
#include "novelty_detection/io/reference_sweeps.h"
#include "process_run.h"

namespace fs = std::filesystem;
using namespace novelty_detection;

namespace {

const fs::path kBin = NOVELTY_BIN_DIR;

using process_run::ProcessRun;
using process_run::run;

std::string roslaunch(const std::string& args) {
  return process_run::roslaunch("build_reference.launch", args, 0, 240);
}

std::vector<int> readLabels(const fs::path& path) {
  std::vector<int> v;
  std::ifstream in(path);
  for (int x; in >> x;) v.push_back(x);
  return v;
}

class BuildReference : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("novelty_build_ref_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    const ProcessRun sim = run((kBin / "simulate_scans").string() + " --out " +
                               (dir_ / "scene").string() + " --seed 1 --novelties 2");
    ASSERT_EQ(sim.code, 0) << sim.out;
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

}  // namespace

TEST_F(BuildReference, BagToReferenceDirectoryToDetection) {
  const fs::path ref = dir_ / "route";
  const ProcessRun launch =
      run(roslaunch("bag:=" + (dir_ / "scene" / "scans.bag").string() +
                    " sensor_frame:=laser max_sweeps:=1 output:=" + ref.string()));
  ASSERT_NE(launch.out.find("saved 1 sweeps"), std::string::npos) << launch.out;
  const ReferenceMap map = loadReference(ref.string());
  ASSERT_EQ(map.views.origins.size(), 1u);
  // Every point of the reference sweep is kept, and its viewpoint is the scene's.
  const CloudFile truth = loadCloudFile((dir_ / "scene" / "ref.pcd").string());
  EXPECT_EQ(map.cloud.size(), truth.cloud.size());
  EXPECT_LT((map.views.origins[0].cast<double>() - truth.T_frame_sensor.translation()).norm(),
            1e-3);

  const ProcessRun detect =
      run((kBin / "novelty_detect").string() + " --reference " + ref.string() + " --current " +
          (dir_ / "scene" / "cur.pcd").string() + " --out " + (dir_ / "out").string());
  ASSERT_EQ(detect.code, 0) << detect.out;
  const std::vector<int> labels = readLabels(dir_ / "out" / "labels.txt");
  const std::vector<int> gt = readLabels(dir_ / "scene" / "gt_labels.txt");
  ASSERT_EQ(labels.size(), gt.size());
  std::size_t tp = 0, fp = 0, fn = 0;
  for (std::size_t i = 0; i < gt.size(); ++i) {
    tp += labels[i] > 0 && gt[i] > 0;
    fp += labels[i] > 0 && gt[i] <= 0;
    fn += labels[i] <= 0 && gt[i] > 0;
  }
  const double f1 = 2.0 * tp / std::max<std::size_t>(1, 2 * tp + fp + fn);
  std::printf("reference from the bag: F1 %.3f (%zu tp, %zu fp, %zu fn)\n", f1, tp, fp, fn);
  EXPECT_GE(f1, 0.8);
  std::ifstream in(dir_ / "out" / "report.json");
  const nlohmann::json report = nlohmann::json::parse(in);
  EXPECT_TRUE(report["visibility_checked"].get<bool>());
  EXPECT_TRUE(report["disappearances_checked"].get<bool>());
  EXPECT_EQ(report["num_segments"].get<int>(), 2);
}

// A patrol route: a bag of 8 sweeps from 8 poses becomes a reference directory of 8 sweeps,
// each with its pose, and a current sweep from a pose between them is detected against it.
TEST_F(BuildReference, RouteBagToReferenceDirectoryToDetection) {
  const ProcessRun sim = run((kBin / "simulate_scans").string() + " --out " +
                             (dir_ / "route_scene").string() + " --route 8 --seed 3");
  ASSERT_EQ(sim.code, 0) << sim.out;
  const fs::path ref = dir_ / "route_map";
  const ProcessRun launch = run(roslaunch("bag:=" + (dir_ / "route_scene" / "route.bag").string() +
                                          " sensor_frame:=laser output:=" + ref.string()));
  ASSERT_NE(launch.out.find("saved 8 sweeps"), std::string::npos) << launch.out;
  const ReferenceMap map = loadReference(ref.string());
  ASSERT_EQ(map.views.origins.size(), 8u);
  // Eight different poses along the route.
  EXPECT_GT((map.views.origins.front() - map.views.origins.back()).norm(), 3.0f);

  const ProcessRun detect = run(
      (kBin / "novelty_detect").string() + " --reference " + ref.string() + " --current " +
      (dir_ / "route_scene" / "cur_0.pcd").string() + " --out " + (dir_ / "route_out").string());
  ASSERT_EQ(detect.code, 0) << detect.out;
  const std::vector<int> labels = readLabels(dir_ / "route_out" / "labels.txt");
  const std::vector<int> gt = readLabels(dir_ / "route_scene" / "gt_labels_0.txt");
  ASSERT_EQ(labels.size(), gt.size());
  std::size_t tp = 0, fp = 0, fn = 0;
  std::map<int, std::pair<std::size_t, std::size_t>> segments;  // id: (points, on changes)
  std::size_t object = 0, object_found = 0;
  for (std::size_t i = 0; i < gt.size(); ++i) {
    tp += labels[i] > 0 && gt[i] > 0;
    fp += labels[i] > 0 && gt[i] <= 0;
    fn += labels[i] <= 0 && gt[i] > 0;
    if (labels[i] > 0) {
      ++segments[labels[i]].first;
      segments[labels[i]].second += gt[i] > 0;
    }
    object += gt[i] == 1;
    object_found += gt[i] == 1 && labels[i] > 0;
  }
  const double f1 = 2.0 * tp / std::max<std::size_t>(1, 2 * tp + fp + fn);
  std::printf("route map from the bag: F1 %.3f (%zu tp, %zu fp, %zu fn), %zu segments\n", f1, tp,
              fp, fn, segments.size());
  EXPECT_GE(f1, 0.8);
  EXPECT_GE(object_found, 0.8 * object);  // the object that stays
  // No false segment (mostly off the changes) over 1 % of the sweep: the suite's bar (a patch
  // of floor seen densely from the current pose and only along sparse lines from the route's
  // poses may stay below it).
  for (const auto& [id, counts] : segments) {
    if (2 * counts.second <= counts.first) {
      EXPECT_LT(counts.first, 0.01 * gt.size()) << "false segment " << id;
    }
  }
  std::ifstream in(dir_ / "route_out" / "report.json");
  const nlohmann::json report = nlohmann::json::parse(in);
  EXPECT_TRUE(report["visibility_checked"].get<bool>());
  EXPECT_EQ(report["num_segments"].get<std::size_t>(), segments.size());
}

TEST_F(BuildReference, AFailedSaveIsFatal) {
  // A file where the output's parent directory should be.
  std::ofstream(dir_ / "blocker") << "x";
  const ProcessRun launch = run(roslaunch(
      "bag:=" + (dir_ / "scene" / "scans.bag").string() +
      " sensor_frame:=laser max_sweeps:=1 output:=" + (dir_ / "blocker" / "map").string()));
  EXPECT_NE(launch.out.find("the reference was NOT saved"), std::string::npos) << launch.out;
  EXPECT_NE(launch.out.find("exit code 1"), std::string::npos) << launch.out;
  // A sweep in the map frame without a sensor frame has no pose: refused by name.
  const ProcessRun no_pose = run(roslaunch("bag:=" + (dir_ / "scene" / "scans.bag").string() +
                                           " max_sweeps:=1 output:=" + (dir_ / "r2").string()));
  EXPECT_NE(no_pose.out.find("~sensor_frame is not set"), std::string::npos) << no_pose.out;
  EXPECT_FALSE(fs::exists(dir_ / "r2"));
}

namespace {

/// build_reference.launch with the tilt scan assembler, and `play` (rosbag play commands)
/// run only once the nodes listen: the assembler to the lines and to /tf, the saver to the
/// sweeps (`rostopic info`); no fixed delay guarantees it on a loaded machine. The launch's
/// output, then "listening: 1".
std::string assembleOnceListening(const std::string& play, const fs::path& out,
                                  const fs::path& log) {
  const std::string listens =
      "rostopic info /scan 2>/dev/null | grep -q tilt_scan_assembler && "
      "rostopic info /tf 2>/dev/null | grep -q tilt_scan_assembler && "
      "rostopic info /assembled_sweep 2>/dev/null | grep -q build_reference";
  return "export ROS_MASTER_URI=http://localhost:" + process_run::masterPort(0) + "; " +
         roslaunch("play:=false assemble_scans:=true sensor_frame:=laser output:=" + out.string()) +
         " > " + log.string() + " 2>&1 & launch=$!; listening=0; for i in $(seq 1 240); do if " +
         listens + "; then listening=1; break; fi; sleep 0.5; done; " + play +
         "; wait $launch; cat " + log.string() + "; echo listening: $listening";
}

/// rosbag play of the scan lines and tf of `bag` with its clock, `args` added, as player
/// `name`. The player starts paused and is let go (a space on its standard input) once the
/// connections between it and the assembler for /scan and /tf, and between it and the saver
/// for /tf, are up on both ends (`rosnode info`): the bag's first tf message, sent before the
/// assembler has connected, is lost to it, and with it the first line, whose transform tf
/// then can only extrapolate; the saver looks up each sweep's sensor pose in its own tf.
/// Waiting for any subscriber is not enough, and neither is the subscriber's end alone: it
/// lists the link once it has sent its header, before the player has read it and added the
/// subscriber to the topic's, and a message published in between is lost.
std::string playBag(const fs::path& bag, const std::string& args, const std::string& name) {
  const std::string fifo = "\"$TMPDIR_PLAY/" + name + "\"";
  // Each node's connections once per poll (`rosnode info` starts a Python process), then
  // `peer` among those for `topic` (one " * topic:" entry a link, its peer on the next line:
  // "* to: /peer" outbound, "* to: /peer (uri)" inbound).
  const auto linked = [](const std::string& connections, const std::string& topic,
                         const std::string& peer) {
    return "echo \"$" + connections + "\" | grep -A1 '^ \\* topic: " + topic + "$' | grep -qE '" +
           peer + "( |$)' ";
  };
  const auto read = [](const std::string& connections, const std::string& node) {
    return connections + "=$(rosnode info " + node + " 2>/dev/null | sed -n '/^Connections/,$p'); ";
  };
  const std::string connected =
      read("assembler_links", "/tilt_scan_assembler") + read("saver_links", "/build_reference") +
      read("player_links", "/" + name) + linked("assembler_links", "/scan", "/" + name) + "&& " +
      linked("assembler_links", "/tf", "/" + name) + "&& " +
      linked("saver_links", "/tf", "/" + name) + "&& " +
      linked("player_links", "/scan", "/tilt_scan_assembler") + "&& " +
      linked("player_links", "/tf", "/tilt_scan_assembler") + "&& " +
      linked("player_links", "/tf", "/build_reference");
  return "TMPDIR_PLAY=$(mktemp -d); mkfifo " + fifo + "; timeout 120 rosbag play --clock -q " +
         "--pause " + args + " " + bag.string() + " --topics /scan /tf __name:=" + name + " < " +
         fifo + " & player=$!; exec 3>" + fifo + "; for i in $(seq 1 240); do if " + connected +
         "; then break; fi; sleep 0.5; done; printf ' ' >&3; wait $player; exec 3>&-; rm -r " +
         "\"$TMPDIR_PLAY\"";
}

/// The lines of a launch's output that tell what became of the lines and sweeps (the nodes'
/// warnings and errors, each sweep, the master), ahead of the whole output.
std::string whatHappened(const std::string& out) {
  std::istringstream in(out);
  std::string summary;
  for (std::string line; std::getline(in, line);) {
    for (const char* word : {"WARN", "ERROR", "FATAL", "sweep", "master", "listening"}) {
      if (line.find(word) != std::string::npos) {
        summary += line + "\n";
        break;
      }
    }
  }
  return summary + "---- the whole output:\n" + out;
}

/// The points of each of the first `sweeps` sweeps of the reference directory `dir`.
std::vector<std::size_t> sweepSizes(const fs::path& dir, std::size_t sweeps) {
  const ReferenceMap map = loadReference(dir.string());
  std::vector<std::size_t> sizes(sweeps, 0);
  for (std::uint32_t k : map.views.sweep)
    if (k < sweeps) ++sizes[k];
  return sizes;
}

}  // namespace

TEST_F(BuildReference, TheAssemblerKeepsEveryLineAtAnyPlaybackRate) {
  // The bag's two sweeps rebuilt from its LaserScan lines and tf (a sawtooth tilt: each
  // sweep starts again at the lowest line) hold every return of the simulator's sweeps.
  const std::size_t ref_points = loadCloud((dir_ / "scene" / "ref.pcd").string()).size();
  const std::size_t cur_points = loadCloud((dir_ / "scene" / "cur.pcd").string()).size();
  const fs::path bag = dir_ / "scene" / "scans.bag";
  for (const char* rate : {"0.2", "1", "5"}) {
    const fs::path out = dir_ / (std::string("assembled_") + rate);
    const ProcessRun launch =
        run(assembleOnceListening(playBag(bag, std::string("-r ") + rate, "bag_player"), out,
                                  dir_ / (std::string("launch_") + rate + ".log")));
    const std::string what = "rate " + std::string(rate) + "\n" + whatHappened(launch.out);
    // A master of its own: nodes of another test on a shared one would add their messages.
    ASSERT_NE(launch.out.find("auto-starting new master"), std::string::npos) << what;
    ASSERT_NE(launch.out.find("listening: 1"), std::string::npos) << what;
    ASSERT_NE(launch.out.find("saved 2 sweeps"), std::string::npos) << what;
    const std::vector<std::size_t> sizes = sweepSizes(out, 2);
    EXPECT_EQ(sizes[0], ref_points) << what;
    EXPECT_EQ(sizes[1], cur_points) << what;
  }
}

TEST_F(BuildReference, TheAssemblerKeepsTheLinesBeforeAPause) {
  // The first line (and its transform), then two seconds of nothing, then the rest: a pause
  // longer than the idle timeout right after a sweep's first line (a stalled player, or a
  // loaded machine), which lost that line when the idle timer closed the one-line sweep.
  const std::size_t ref_points = loadCloud((dir_ / "scene" / "ref.pcd").string()).size();
  const std::size_t cur_points = loadCloud((dir_ / "scene" / "cur.pcd").string()).size();
  const fs::path bag = dir_ / "scene" / "scans.bag";
  const fs::path out = dir_ / "assembled_pause";
  const ProcessRun launch = run(assembleOnceListening(
      playBag(bag, "-u 0.01", "bag_head") + "; sleep 2; " + playBag(bag, "-s 0.01", "bag_rest"),
      out, dir_ / "launch_pause.log"));
  const std::string what = whatHappened(launch.out);
  ASSERT_NE(launch.out.find("auto-starting new master"), std::string::npos) << what;
  ASSERT_NE(launch.out.find("listening: 1"), std::string::npos) << what;
  ASSERT_NE(launch.out.find("saved 2 sweeps"), std::string::npos) << what;
  const std::vector<std::size_t> sizes = sweepSizes(out, 2);
  EXPECT_EQ(sizes[0], ref_points) << what;
  EXPECT_EQ(sizes[1], cur_points) << what;
}
