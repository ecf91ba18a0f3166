// The detector's reference services work, and bad sweeps (empty, all NaN, no x field,
// unknown frame) are refused with a warning while the next good sweep is still served.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <rosbag/bag.h>
#include <rosgraph_msgs/Log.h>
#include <std_srvs/Trigger.h>

#include <unistd.h>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <future>
#include <map>
#include <mutex>
#include <random>
#include <vector>

#include "novelty_detection/Detect.h"
#include "novelty_detection/NoveltyArray.h"
#include "novelty_detection/SaveReference.h"
#include "novelty_detection/SetReference.h"
#include "novelty_detection/io/cloud_io.h"
#include "test_helpers.h"

using test_helpers::waitFor;

class DetectorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    pub_ = nh_.advertise<sensor_msgs::PointCloud2>("/sweep", 5);
    sub_ = nh_.subscribe<novelty_detection::NoveltyArray>(
        "/detector/novelties", 10, [this](const novelty_detection::NoveltyArray::ConstPtr& m) {
          std::lock_guard<std::mutex> lock(mutex_);
          results_.push_back(*m);
        });
    log_sub_ = nh_.subscribe<rosgraph_msgs::Log>("/rosout", 100,
                                                 [this](const rosgraph_msgs::Log::ConstPtr& m) {
                                                   std::lock_guard<std::mutex> lock(mutex_);
                                                   if (m->level >= rosgraph_msgs::Log::WARN)
                                                     warnings_.push_back(m->msg);
                                                 });
    diag_sub_ = nh_.subscribe<diagnostic_msgs::DiagnosticArray>(
        "/diagnostics", 10, [this](const diagnostic_msgs::DiagnosticArray::ConstPtr& m) {
          for (const auto& st : m->status) {
            if (st.name.find("novelty detector") == std::string::npos) continue;
            std::lock_guard<std::mutex> lock(mutex_);
            ++diagnostics_seen_;
            for (const auto& kv : st.values) counters_[kv.key] = kv.value;
          }
        });
    ASSERT_TRUE(waitFor(
        [this] {
          return pub_.getNumSubscribers() > 0 && sub_.getNumPublishers() > 0 &&
                 log_sub_.getNumPublishers() > 0;
        },
        30.0))
        << "detector not connected";
    ASSERT_TRUE(ros::service::waitForService("/detector/capture_reference", 30000));
    ASSERT_TRUE(ros::service::waitForService("/detector/detect", 30000));
    room_ = test_helpers::corridor(false, 1);
  }

  bool hasWarning(const std::string& needle) {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& w : warnings_) {
      if (w.find(needle) != std::string::npos) return true;
    }
    return false;
  }
  // Publishes `msg` (re-stamped) every 3 s until a warning containing `needle` arrives: the
  // manager's /rosout connection may come up after the first warning.
  bool publishUntilWarning(sensor_msgs::PointCloud2 msg, const std::string& needle) {
    ros::WallTime next;
    return waitFor(
        [&] {
          if (hasWarning(needle)) return true;
          if (ros::WallTime::now() >= next) {
            msg.header.stamp = ros::Time::now();
            pub_.publish(msg);
            next = ros::WallTime::now() + ros::WallDuration(3.0);
          }
          return false;
        },
        25.0);
  }
  // Publishes a good sweep and waits for its result (stamp identifies it).
  bool goodSweepIsServed() {
    const ros::Time stamp = ros::Time::now();
    pub_.publish(test_helpers::toMsg(room_, "map", stamp));
    return waitFor(
        [&] {
          std::lock_guard<std::mutex> lock(mutex_);
          for (const auto& r : results_) {
            if (r.header.stamp == stamp && r.header.frame_id == "map") return true;
          }
          return false;
        },
        20.0);
  }
  // Captures the room as reference through ~capture_reference.
  void captureRoom() {
    std_srvs::Trigger trigger;
    ASSERT_TRUE(ros::service::call("/detector/capture_reference", trigger));
    EXPECT_TRUE(trigger.response.success) << trigger.response.message;
    pub_.publish(test_helpers::toMsg(room_, "map", ros::Time::now()));
    // The capture is asynchronous: save_reference succeeds once it happened.
    novelty_detection::SaveReference save;
    save.request.path = tmpPath("captured.pcd");
    ASSERT_TRUE(waitFor(
        [&] {
          return ros::service::call("/detector/save_reference", save) && save.response.success;
        },
        20.0))
        << save.response.message;
    EXPECT_EQ(novelty_detection::loadCloud(save.request.path).size(), room_.size());
  }
  std::string tmpPath(const std::string& name) {
    return "/tmp/novelty_rostest_" + std::to_string(getpid()) + "_" + name;
  }

  long counter(const std::string& key) {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = counters_.find(key);
    return it == counters_.end() ? -1 : std::stol(it->second);
  }
  std::size_t diagnosticsSeen() {
    std::lock_guard<std::mutex> lock(mutex_);
    return diagnostics_seen_;
  }
  bool hasResult(const ros::Time& stamp) {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& r : results_)
      if (r.header.stamp == stamp) return true;
    return false;
  }

  ros::NodeHandle nh_;
  ros::Publisher pub_;
  ros::Subscriber sub_, log_sub_, diag_sub_;
  std::map<std::string, std::string> counters_;
  std::size_t diagnostics_seen_ = 0;
  std::mutex mutex_;
  std::vector<novelty_detection::NoveltyArray> results_;
  std::vector<std::string> warnings_;
  novelty_detection::Cloud room_;
};

TEST_F(DetectorTest, ReferenceServicesAndDetect) {
  // Without a reference, a sweep yields a warning and no result.
  EXPECT_TRUE(publishUntilWarning(test_helpers::toMsg(room_, "map", ros::Time::now()),
                                  "no reference map yet"));
  novelty_detection::SaveReference save;
  save.request.path = tmpPath("none.pcd");
  ASSERT_TRUE(ros::service::call("/detector/save_reference", save));
  EXPECT_FALSE(save.response.success);

  captureRoom();

  // Saves stay inside ~save_directory (/tmp here): other places, '..' and a symlink that
  // leads out are refused by name; nothing is written there.
  for (const std::string& outside :
       {std::string("/etc/novelty_map.pcd"), std::string("../novelty_map.pcd"),
        std::string("/tmp/../etc/novelty_map.pcd")}) {
    novelty_detection::SaveReference bad;
    bad.request.path = outside;
    ASSERT_TRUE(ros::service::call("/detector/save_reference", bad));
    EXPECT_FALSE(bad.response.success) << outside;
    EXPECT_NE(bad.response.message.find("outside ~save_directory"), std::string::npos)
        << bad.response.message;
  }
  const std::string link = tmpPath("link_out");
  std::remove(link.c_str());
  ASSERT_EQ(::symlink("/etc", link.c_str()), 0);
  novelty_detection::SaveReference via_link;
  via_link.request.path = link + "/novelty_map.pcd";
  ASSERT_TRUE(ros::service::call("/detector/save_reference", via_link));
  EXPECT_FALSE(via_link.response.success) << via_link.response.message;
  std::remove(link.c_str());
  // A relative path is taken inside the directory.
  novelty_detection::SaveReference relative;
  relative.request.path = "novelty_rostest_" + std::to_string(getpid()) + "_relative.pcd";
  ASSERT_TRUE(ros::service::call("/detector/save_reference", relative));
  EXPECT_TRUE(relative.response.success) << relative.response.message;
  EXPECT_EQ(novelty_detection::loadCloud("/tmp/" + relative.request.path).size(), room_.size());
  std::remove(("/tmp/" + relative.request.path).c_str());

  // set_reference: a missing file is refused clearly, a saved one is loaded.
  novelty_detection::SetReference set;
  set.request.path = tmpPath("does_not_exist.pcd");
  ASSERT_TRUE(ros::service::call("/detector/set_reference", set));
  EXPECT_FALSE(set.response.success);
  EXPECT_NE(set.response.message.find("does_not_exist"), std::string::npos) << set.response.message;
  // A file claiming more points than preprocess/max_points (2,000,000) is refused from its
  // header, before its body is read, naming the limit; the reference in use stays.
  const std::string oversized = tmpPath("oversized.pcd");
  {
    std::ofstream out(oversized);
    out << "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 30000000\n"
           "HEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 30000000\nDATA binary\n";
  }
  set.request.path = oversized;
  ASSERT_TRUE(ros::service::call("/detector/set_reference", set));
  EXPECT_FALSE(set.response.success);
  EXPECT_NE(set.response.message.find("30000000 points, more than preprocess/max_points = 2000000"),
            std::string::npos)
      << set.response.message;
  std::remove(oversized.c_str());
  set.request.path = tmpPath("captured.pcd");
  ASSERT_TRUE(ros::service::call("/detector/set_reference", set));
  EXPECT_TRUE(set.response.success) << set.response.message;

  // detect on a cloud given in the laser frame (1, 0, 0.5 from map): every point labelled.
  novelty_detection::Cloud in_laser = room_;
  for (auto& p : in_laser) {
    p.x -= 1.0f;
    p.z -= 0.5f;
  }
  in_laser.push_back(novelty_detection::PointT(NAN, NAN, NAN));
  novelty_detection::Detect detect;
  detect.request.cloud = test_helpers::toMsg(in_laser, "laser", ros::Time(0));
  ASSERT_TRUE(ros::service::call("/detector/detect", detect));
  EXPECT_TRUE(detect.response.success) << detect.response.message;
  EXPECT_EQ(detect.response.labelled_cloud.width * detect.response.labelled_cloud.height,
            in_laser.size());
  EXPECT_EQ(detect.response.novelties.header.frame_id, "map");
  // (Whether this synthetic room counts as unchanged is the pipeline's business, tested on
  // realistic simulated scenes in novelty_scenes.test.)

  EXPECT_TRUE(goodSweepIsServed());
  std::remove(tmpPath("captured.pcd").c_str());
}

TEST_F(DetectorTest, BadSweepsAreRefusedAndTheNextGoodOneIsServed) {
  captureRoom();
  ASSERT_TRUE(goodSweepIsServed());

  novelty_detection::Cloud empty;
  EXPECT_TRUE(publishUntilWarning(test_helpers::toMsg(empty, "map", ros::Time::now()),
                                  "the sweep is empty"));
  EXPECT_TRUE(goodSweepIsServed());

  novelty_detection::Cloud nans;
  for (int i = 0; i < 100; ++i) nans.push_back(novelty_detection::PointT(NAN, NAN, NAN));
  EXPECT_TRUE(
      publishUntilWarning(test_helpers::toMsg(nans, "map", ros::Time::now()), "no finite point"));
  EXPECT_TRUE(goodSweepIsServed());

  sensor_msgs::PointCloud2 no_x = test_helpers::toMsg(room_, "map", ros::Time::now());
  no_x.fields[0].name = "intensity";
  EXPECT_TRUE(publishUntilWarning(no_x, "no 'x' field"));
  EXPECT_TRUE(goodSweepIsServed());

  EXPECT_TRUE(publishUntilWarning(test_helpers::toMsg(room_, "no_such_frame", ros::Time::now()),
                                  "'no_such_frame' is unknown to tf"));
  EXPECT_TRUE(goodSweepIsServed());

  // A sweep 500 m off the map is not "no change": no result, a warning, diagnostics ERROR
  // with the overlap, and the next good sweep is compared again.
  novelty_detection::Cloud far = room_;
  for (auto& p : far) p.x += 500.0f;
  std::size_t results_before = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    results_before = results_.size();
  }
  EXPECT_TRUE(publishUntilWarning(test_helpers::toMsg(far, "map", ros::Time::now()),
                                  "does not overlap the reference"));
  EXPECT_TRUE(waitFor([&] { return counter("sweeps not compared (no overlap)") >= 1; }, 10.0));
  {
    std::lock_guard<std::mutex> lock(mutex_);
    EXPECT_EQ(results_.size(), results_before) << "a sweep off the map was answered";
    EXPECT_LT(std::stod(counters_["last overlap"]), 0.1);
  }
  EXPECT_TRUE(goodSweepIsServed());
  EXPECT_TRUE(waitFor(
      [&] {
        std::lock_guard<std::mutex> lock(mutex_);
        return std::stod(counters_["last overlap"]) > 0.9;
      },
      10.0));

  // A sweep in the laser frame goes through tf.
  novelty_detection::Cloud in_laser = room_;
  for (auto& p : in_laser) p.x -= 1.0f;
  const ros::Time stamp = ros::Time::now();
  pub_.publish(test_helpers::toMsg(in_laser, "laser", stamp));
  EXPECT_TRUE(waitFor(
      [&] {
        std::lock_guard<std::mutex> lock(mutex_);
        return !results_.empty() && results_.back().header.stamp == stamp;
      },
      20.0));
}

TEST_F(DetectorTest, DiagnosticsArePublishedOncePerSecond) {
  // The updater's period is 1 s: about five messages in 5 s of an idle node (two or three if
  // it were asked only at its own period, when it finds the period not quite over every
  // other time).
  ASSERT_TRUE(waitFor([&] { return diagnosticsSeen() > 0; }, 10.0));
  const std::size_t start = diagnosticsSeen();
  waitFor([] { return false; }, 5.0);
  const std::size_t seen = diagnosticsSeen() - start;
  EXPECT_GE(seen, 4u);
  EXPECT_LE(seen, 6u);
}

TEST_F(DetectorTest, ServicesRunBesideSweepsAndLostSweepsAreCounted) {
  captureRoom();
  ASSERT_TRUE(goodSweepIsServed());
  // A detect call on a large cloud (the room 300 times over, jittered) takes seconds. While
  // it runs, sweeps keep being received and served and /diagnostics keeps coming: the
  // services have their own thread.
  novelty_detection::Cloud big;
  std::mt19937 rng(5);
  std::normal_distribution<float> jitter(0.f, 0.005f);
  for (int copy = 0; copy < 300; ++copy)
    for (const auto& p : room_)
      big.push_back(
          novelty_detection::PointT(p.x + jitter(rng), p.y + jitter(rng), p.z + jitter(rng)));
  novelty_detection::Detect detect;
  detect.request.cloud = test_helpers::toMsg(big, "map", ros::Time::now());
  ASSERT_TRUE(waitFor([&] { return counter("sweeps lost upstream") >= 0; }, 10.0));
  const long lost_before = counter("sweeps lost upstream");

  const auto t0 = std::chrono::steady_clock::now();
  auto call = std::async(std::launch::async,
                         [&] { return ros::service::call("/detector/detect", detect); });
  // Sweeps every 0.3 s while the call runs (at most 6); served and diagnostics are checked
  // only while the call is still running.
  auto running = [&] {
    return call.wait_for(std::chrono::seconds(0)) != std::future_status::ready;
  };
  std::vector<ros::Time> sent_during_call;
  std::size_t diagnostics_during_call = 0;
  const std::size_t diagnostics_at_start = diagnosticsSeen();
  bool served_during_call = false;
  auto watch = [&] {
    ros::spinOnce();
    if (!running()) return;
    for (const ros::Time& stamp : sent_during_call) served_during_call |= hasResult(stamp);
    diagnostics_during_call = diagnosticsSeen() - diagnostics_at_start;
  };
  for (int i = 0; i < 6 && running(); ++i) {
    sensor_msgs::PointCloud2 msg = test_helpers::toMsg(room_, "map", ros::Time::now());
    pub_.publish(msg);
    sent_during_call.push_back(msg.header.stamp);
    const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(0.3);
    while (ros::WallTime::now() < until) {
      watch();
      ros::WallDuration(0.01).sleep();
    }
  }
  while (running()) {
    watch();
    ros::WallDuration(0.02).sleep();
  }
  const double call_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_TRUE(call.get());
  EXPECT_TRUE(detect.response.success) << detect.response.message;
  ASSERT_GE(sent_during_call.size(), 3u)
      << "the detect call (" << call_s << " s) must outlast several sweeps sent during it";
  EXPECT_TRUE(served_during_call) << "no sweep served during a " << call_s << " s detect call";
  EXPECT_GE(diagnostics_during_call, 1u) << "no /diagnostics during a " << call_s << " s call";

  // A recording whose sweeps 4 and 5 never made it into the bag (header seq 1, 2, 3, 6, 7,
  // 8), replayed by rosbag play: the node counts the 2 lost sweeps of that publisher.
  const std::string bag_path = tmpPath("gaps.bag");
  {
    rosbag::Bag bag(bag_path, rosbag::bagmode::Write);
    const ros::Time start = ros::Time::now();
    int i = 0;
    for (std::uint32_t seq : {1u, 2u, 3u, 6u, 7u, 8u}) {
      sensor_msgs::PointCloud2 msg =
          test_helpers::toMsg(room_, "map", start + ros::Duration(0.2 * (seq - 1)));
      msg.header.seq = seq;
      bag.write("/sweep", start + ros::Duration(0.2 * i++), msg);
    }
  }
  const std::string play = "rosbag play -q --wait-for-subscribers " + bag_path + " > /dev/null";
  ASSERT_EQ(std::system(play.c_str()), 0) << play;
  EXPECT_TRUE(waitFor([&] { return counter("sweeps lost upstream") == lost_before + 2; }, 10.0))
      << counter("sweeps lost upstream") << " lost, " << lost_before << " before";
  std::remove(bag_path.c_str());
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_detector_robustness");
  ros::NodeHandle keep_alive;  // the node shuts down when its last NodeHandle goes away
  return RUN_ALL_TESTS();
}
