// Live tuning: the reconfigure server starts at the loaded parameters and applies updates.
#include <dynamic_reconfigure/Reconfigure.h>
#include <gtest/gtest.h>
#include <ros/ros.h>

namespace {

int intParam(const dynamic_reconfigure::Config& c, const std::string& name) {
  for (const auto& e : c.ints) {
    if (e.name == name) return e.value;
  }
  return -1;
}

}  // namespace

TEST(LiveTuning, StartsAtLoadedValuesAndAppliesUpdates) {
  ros::NodeHandle nh;
  const std::string service = "/detector/tuning/set_parameters";
  ASSERT_TRUE(ros::service::waitForService(service, ros::Duration(30.0)));

  // An empty request returns the current configuration.
  dynamic_reconfigure::Reconfigure srv;
  ASSERT_TRUE(ros::service::call(service, srv));
  EXPECT_EQ(intParam(srv.response.config, "segmentation_min_segment_points"), 17);

  dynamic_reconfigure::Reconfigure update;
  dynamic_reconfigure::IntParameter p;
  p.name = "segmentation_min_segment_points";
  p.value = 123;
  update.request.config.ints.push_back(p);
  ASSERT_TRUE(ros::service::call(service, update));
  EXPECT_EQ(intParam(update.response.config, "segmentation_min_segment_points"), 123);

  int on_server = -1;
  EXPECT_TRUE(nh.getParam("/detector/tuning/segmentation_min_segment_points", on_server));
  EXPECT_EQ(on_server, 123);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_live_tuning");
  ros::AsyncSpinner spinner(1);
  spinner.start();
  return RUN_ALL_TESTS();
}
