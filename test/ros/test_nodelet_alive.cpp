// The detector nodelet loads into a real manager and announces itself; invalid parameters
// (a value out of range, a wrong type) make it refuse to start with a message naming them.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <std_msgs/String.h>

#include <string>

namespace {
std::string statusOf(const std::string& node) {
  ros::NodeHandle nh;
  std::string status;
  ros::Subscriber sub = nh.subscribe<std_msgs::String>(
      "/" + node + "/status", 1,
      [&](const std_msgs::String::ConstPtr& msg) { status = msg->data; });
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(30.0);
  while (status.empty() && ros::WallTime::now() < deadline && ros::ok()) {
    ros::spinOnce();
    ros::WallDuration(0.05).sleep();
  }
  return status;
}
}  // namespace

TEST(NodeletAlive, PublishesReadyStatus) { EXPECT_EQ(statusOf("detector"), "ready"); }

TEST(NodeletAlive, RefusesAnOutOfRangeValue) {
  const std::string status = statusOf("bad_value");
  EXPECT_EQ(status.rfind("error: invalid parameters", 0), 0u) << status;
  EXPECT_NE(status.find("max_components"), std::string::npos) << status;
}

TEST(NodeletAlive, RefusesAWrongType) {
  const std::string status = statusOf("bad_type");
  EXPECT_NE(status.find("/bad_type/preprocess/outlier_k' must be an integer, got a string"),
            std::string::npos)
      << status;
}

TEST(NodeletAlive, DetectorServicesAreAdvertised) {
  for (const char* s : {"capture_reference", "set_reference", "save_reference", "detect"}) {
    EXPECT_TRUE(ros::service::waitForService(std::string("/detector/") + s, 10000)) << s;
  }
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_nodelet_alive");
  ros::NodeHandle keep_alive;  // the node shuts down when its last NodeHandle goes away
  return RUN_ALL_TESTS();
}
