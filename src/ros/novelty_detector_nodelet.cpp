#include "novelty_detection/ros/novelty_detector_nodelet.h"

#include <pluginlib/class_list_macros.hpp>
#include <std_msgs/String.h>

namespace novelty_detection {

NoveltyDetectorNodelet::NoveltyDetectorNodelet() = default;
NoveltyDetectorNodelet::~NoveltyDetectorNodelet() = default;

void NoveltyDetectorNodelet::onInit() {
  ros::NodeHandle& pnh = getPrivateNodeHandle();
  status_pub_ = pnh.advertise<std_msgs::String>("status", 1, true);
  std_msgs::String msg;
  msg.data = "ready";
  status_pub_.publish(msg);
  NODELET_INFO("novelty detector started");
}

}  // namespace novelty_detection

PLUGINLIB_EXPORT_CLASS(novelty_detection::NoveltyDetectorNodelet, nodelet::Nodelet)
