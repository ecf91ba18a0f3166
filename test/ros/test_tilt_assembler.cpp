// A laser at (0, 0, 1) in map nods from -0.3 to +0.3 rad pitch in 21 lines and back in 20:
// the assembler publishes one sweep per direction (closed by the reversal, then by the idle
// timeout), every valid beam projected at its range from the laser origin. A sweep too short
// to publish is reported.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Log.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2/LinearMath/Quaternion.h>
#include <tf2_msgs/TFMessage.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "novelty_detection/ros/conversions.h"
#include "test_helpers.h"

using test_helpers::waitFor;

namespace {

/// One line of 11 beams (one without a return, one beyond range_max: 9 points) per pitch,
/// 25 ms apart, each with the laser's pose at (0, 0, 1) in map on /tf.
void publishLines(ros::Publisher& tf_pub, ros::Publisher& scan_pub,
                  const std::vector<double>& pitches) {
  const ros::Time t0 = ros::Time::now();
  for (std::size_t k = 0; k < pitches.size(); ++k) {
    const ros::Time stamp = t0 + ros::Duration(0.025 * k);
    tf2_msgs::TFMessage tf;
    geometry_msgs::TransformStamped t;
    t.header.stamp = stamp;
    t.header.frame_id = "map";
    t.child_frame_id = "laser";
    t.transform.translation.z = 1.0;
    tf2::Quaternion q;
    q.setRPY(0.0, pitches[k], 0.0);
    t.transform.rotation.x = q.x();
    t.transform.rotation.y = q.y();
    t.transform.rotation.z = q.z();
    t.transform.rotation.w = q.w();
    tf.transforms.push_back(t);
    tf_pub.publish(tf);
    sensor_msgs::LaserScan scan;
    scan.header.stamp = stamp;
    scan.header.frame_id = "laser";
    scan.angle_min = -0.5f;
    scan.angle_increment = 0.1f;
    scan.angle_max = 0.5f;
    scan.range_min = 0.1f;
    scan.range_max = 10.0f;
    scan.ranges.assign(11, 2.0f);
    scan.ranges[3] = std::numeric_limits<float>::infinity();  // no return
    scan.ranges[7] = 20.0f;                                   // beyond range_max
    scan_pub.publish(scan);
    ros::WallDuration(0.01).sleep();
  }
}

/// The lines' and tf's publishers and the sweeps received (with their frames).
class TiltAssembler : public ::testing::Test {
 protected:
  void SetUp() override {
    tf_pub_ = nh_.advertise<tf2_msgs::TFMessage>("/tf", 100);
    scan_pub_ = nh_.advertise<sensor_msgs::LaserScan>("/scan", 100);
    sub_ = nh_.subscribe<sensor_msgs::PointCloud2>(
        "/assembler/sweep", 10, [this](const sensor_msgs::PointCloud2::ConstPtr& m) {
          frames_.push_back(m->header.frame_id);
          sweeps_.push_back(novelty_detection::fromPointCloud2(*m));
        });
  }
  /// Whether the assembler is linked to the lines, tf and the sweeps.
  bool connected() const {
    return tf_pub_.getNumSubscribers() > 0 && scan_pub_.getNumSubscribers() > 0 &&
           sub_.getNumPublishers() > 0;
  }

  ros::NodeHandle nh_;
  ros::Publisher tf_pub_, scan_pub_;
  ros::Subscriber sub_;
  std::vector<novelty_detection::Cloud> sweeps_;
  std::vector<std::string> frames_;
};

}  // namespace

TEST_F(TiltAssembler, OneSweepPerTiltDirection) {
  ASSERT_TRUE(waitFor([&] { return connected(); }, 30.0));

  std::vector<double> pitches;
  for (int k = 0; k <= 20; ++k) pitches.push_back(-0.3 + 0.03 * k);
  for (int k = 19; k >= 0; --k) pitches.push_back(-0.3 + 0.03 * k);
  publishLines(tf_pub_, scan_pub_, pitches);
  ASSERT_TRUE(waitFor([&] { return sweeps_.size() >= 2; }, 20.0)) << sweeps_.size() << " sweeps";
  for (const std::string& frame : frames_) EXPECT_EQ(frame, "map");
  EXPECT_EQ(sweeps_[0].size(), 21u * 9u);
  EXPECT_EQ(sweeps_[1].size(), 20u * 9u);
  double max_err = 0.0, min_z = 1e9, max_z = -1e9;
  for (const auto& s : sweeps_) {
    for (const auto& p : s) {
      max_err = std::max(max_err,
                         std::abs(std::sqrt(p.x * p.x + p.y * p.y + (p.z - 1) * (p.z - 1)) - 2.0));
      min_z = std::min<double>(min_z, p.z);
      max_z = std::max<double>(max_z, p.z);
    }
  }
  EXPECT_LT(max_err, 1e-4);
  // Pitch +-0.3 rad about y tilts the beams to z = 1 -+ 2 cos(a) sin(0.3).
  EXPECT_NEAR(max_z, 1 + 2 * std::sin(0.3), 1e-3);
  EXPECT_NEAR(min_z, 1 - 2 * std::sin(0.3), 1e-3);
}

TEST_F(TiltAssembler, ASweepTooShortToPublishIsReported) {
  // Three lines tilting up, then twenty tilting down: the reversal closes a sweep of three
  // lines, fewer than ~min_lines (5). It is not published, and a warning says so; the twenty
  // lines are one sweep.
  std::vector<std::string> warnings;
  // The log of every node: the manager's, the loader's and this one's (no rosout node here).
  ros::Subscriber log =
      nh_.subscribe<rosgraph_msgs::Log>("/rosout", 100, [&](const rosgraph_msgs::Log::ConstPtr& m) {
        if (m->level >= rosgraph_msgs::Log::WARN) warnings.push_back(m->msg);
      });
  ASSERT_TRUE(waitFor([&] { return connected() && log.getNumPublishers() >= 3; }, 30.0));

  std::vector<double> pitches = {-0.3, -0.27, -0.24};
  for (int k = 1; k <= 20; ++k) pitches.push_back(-0.24 - 0.03 * k);
  publishLines(tf_pub_, scan_pub_, pitches);
  const std::string expected =
      "3 line(s) (27 points) not published: closed by a tilt reversal with fewer than "
      "~min_lines (5) lines";
  const auto warned = [&] {
    for (const std::string& w : warnings)
      if (w.find(expected) != std::string::npos) return true;
    return false;
  };
  ASSERT_TRUE(waitFor([&] { return !sweeps_.empty() && warned(); }, 20.0))
      << sweeps_.size() << " sweeps, " << warnings.size() << " warnings";
  ASSERT_EQ(sweeps_.size(), 1u);
  EXPECT_EQ(sweeps_[0].size(), 20u * 9u);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_tilt_assembler");
  ros::NodeHandle keep_alive;
  return RUN_ALL_TESTS();
}
