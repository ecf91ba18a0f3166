// The detector nodelet loads into a real manager and announces itself; invalid parameters
// (a value out of range, a wrong type) make it refuse to start with a message naming them; a
// misspelt parameter is named in its status (and refused with ~strict_parameters); a missing
// reference file is reported on ~status.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <std_msgs/String.h>

#include <string>

namespace {
/// The node's latest status once it starts with `prefix` (any status when empty), or the
/// last one heard when 30 s pass.
std::string statusOf(const std::string& node, const std::string& prefix = "") {
  ros::NodeHandle nh;
  std::string status;
  ros::Subscriber sub = nh.subscribe<std_msgs::String>(
      "/" + node + "/status", 1,
      [&](const std_msgs::String::ConstPtr& msg) { status = msg->data; });
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(30.0);
  while ((status.empty() || status.rfind(prefix, 0) != 0) && ros::WallTime::now() < deadline &&
         ros::ok()) {
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

TEST(NodeletAlive, NamesAMisspeltParameter) {
  const std::string status = statusOf("misspelt");
  EXPECT_EQ(status,
            "ready; unknown parameters ignored: ~gmm/max_component "
            "(~strict_parameters refuses them)");
}

TEST(NodeletAlive, StrictParametersRefuseAMisspeltOne) {
  const std::string status = statusOf("strict");
  EXPECT_EQ(status.rfind("error: invalid parameters: unknown parameter(s) ~gmm/max_component", 0),
            0u)
      << status;
}

TEST(NodeletAlive, ReportsAMissingReferenceFile) {
  const std::string status = statusOf("missing_map", "error");
  EXPECT_EQ(status.rfind("error: cannot use ~reference_file '/nonexistent/novelty_map.pcd'", 0), 0u)
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
