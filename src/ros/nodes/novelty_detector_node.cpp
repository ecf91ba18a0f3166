// Stand-alone node: loads NoveltyDetectorNodelet into this process. Unlike the nodelet,
// which stays loaded and idle on invalid parameters (a manager must not die), the node
// exits with status 1 when its parameters are invalid.
#include <nodelet/loader.h>
#include <ros/ros.h>

#include <exception>

#include "novelty_detection/ros/node_params.h"
#include "novelty_detection/ros/ros_params.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "novelty_detector");
  try {
    const ros::NodeHandle pnh("~");
    novelty_detection::loadRosParams(pnh);
    novelty_detection::loadNodeParams(pnh);
  } catch (const std::exception& e) {
    ROS_FATAL("novelty detector refuses to start: %s", e.what());
    return 1;
  }
  nodelet::Loader loader;
  nodelet::M_string remap(ros::names::getRemappings());
  nodelet::V_string nargv;
  if (!loader.load(ros::this_node::getName(), "novelty_detection/NoveltyDetectorNodelet", remap,
                   nargv)) {
    ROS_FATAL("could not load novelty_detection/NoveltyDetectorNodelet");
    return 1;
  }
  ros::spin();
  return 0;
}
