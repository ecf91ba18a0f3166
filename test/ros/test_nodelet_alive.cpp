// The detector nodelet loads into a real manager and announces itself.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <std_msgs/String.h>

TEST(NodeletAlive, PublishesReadyStatus) {
  ros::NodeHandle nh;
  std::string status;
  ros::Subscriber sub = nh.subscribe<std_msgs::String>(
      "/detector/status", 1, [&](const std_msgs::String::ConstPtr& msg) { status = msg->data; });
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(30.0);
  while (status.empty() && ros::WallTime::now() < deadline && ros::ok()) {
    ros::spinOnce();
    ros::WallDuration(0.05).sleep();
  }
  EXPECT_EQ(status, "ready");
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_nodelet_alive");
  return RUN_ALL_TESTS();
}
