// ROS shell around novelty_detection::Pipeline.
#pragma once

#include <nodelet/nodelet.h>
#include <ros/ros.h>

#include <memory>

namespace novelty_detection {

class NoveltyDetectorNodelet : public nodelet::Nodelet {
 public:
  NoveltyDetectorNodelet();
  ~NoveltyDetectorNodelet() override;

 private:
  void onInit() override;

  ros::Publisher status_pub_;
  ros::WallTimer heartbeat_;
};

}  // namespace novelty_detection
