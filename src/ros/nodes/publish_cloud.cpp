// publish_cloud FILE: publishes a .pcd/.ply cloud as a sensor_msgs/PointCloud2 sweep, to run
// a recorded sweep against the detector without a bag:
//   rosrun novelty_detection publish_cloud sweep.pcd _topic:=/sweep _frame_id:=map _rate:=1
// ~topic (/sweep), ~frame_id (map), ~rate (1.0 Hz; each message stamped now), ~count (0:
// until shut down). An organised cloud (a depth camera's) keeps its width x height layout.
#include <ros/ros.h>

#include <exception>
#include <string>
#include <vector>

#include "novelty_detection/io/cloud_io.h"
#include "novelty_detection/ros/conversions.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "publish_cloud", ros::init_options::AnonymousName);
  std::vector<std::string> args;
  ros::removeROSArgs(argc, argv, args);
  if (args.size() != 2) {
    ROS_FATAL("usage: publish_cloud FILE [_topic:=/sweep] [_frame_id:=map] [_rate:=1] [_count:=0]");
    return 2;
  }
  // The file first: a bad one is refused at once, even before a master is up.
  novelty_detection::Cloud cloud;
  try {
    cloud = novelty_detection::loadCloud(args[1]);
  } catch (const std::exception& e) {
    ROS_FATAL("publish_cloud: %s", e.what());
    return 1;
  }
  ros::NodeHandle nh, pnh("~");
  const std::string topic = pnh.param<std::string>("topic", "/sweep");
  const std::string frame_id = pnh.param<std::string>("frame_id", "map");
  const double rate = pnh.param("rate", 1.0);
  const int count = pnh.param("count", 0);
  if (!(rate > 0.0) || rate > 1000.0 || count < 0 || frame_id.empty()) {
    ROS_FATAL("publish_cloud: ~rate must be in (0, 1000], ~count >= 0, ~frame_id not empty");
    return 2;
  }
  ros::Publisher pub = nh.advertise<sensor_msgs::PointCloud2>(topic, 1);
  ROS_INFO("publish_cloud: %s (%zu points, %u x %u) on %s in frame %s at %.2f Hz", args[1].c_str(),
           cloud.size(), cloud.width, cloud.height, pub.getTopic().c_str(), frame_id.c_str(), rate);
  std_msgs::Header header;
  header.frame_id = frame_id;
  sensor_msgs::PointCloud2 msg = novelty_detection::toPointCloud2(cloud, header);
  ros::Rate loop(rate);
  for (int sent = 0; ros::ok() && (count == 0 || sent < count); ++sent) {
    msg.header.stamp = ros::Time::now();
    msg.header.seq = static_cast<std::uint32_t>(sent);
    pub.publish(msg);
    ros::spinOnce();
    loop.sleep();
  }
  return 0;
}
