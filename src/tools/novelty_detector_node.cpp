// Stand-alone node: loads NoveltyDetectorNodelet into this process.
#include <nodelet/loader.h>
#include <ros/ros.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, "novelty_detector");
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
