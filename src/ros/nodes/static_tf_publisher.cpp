// static_tf_publisher X Y Z YAW PITCH ROLL PARENT CHILD: broadcasts one static transform
// (latched on /tf_static). Debian's tf2_ros has no static_transform_publisher executable.
#include <geometry_msgs/TransformStamped.h>
#include <ros/ros.h>
#include <tf2/LinearMath/Quaternion.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <cstdlib>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  ros::init(argc, argv, "static_tf_publisher", ros::init_options::AnonymousName);
  std::vector<std::string> args;
  ros::removeROSArgs(argc, argv, args);
  if (args.size() != 9) {
    ROS_FATAL("usage: static_tf_publisher X Y Z YAW PITCH ROLL PARENT CHILD (metres, radians)");
    return 1;
  }
  double v[6];
  for (int i = 0; i < 6; ++i) {
    char* end = nullptr;
    v[i] = std::strtod(args[i + 1].c_str(), &end);
    if (end == args[i + 1].c_str() || *end != '\0') {
      ROS_FATAL("static_tf_publisher: '%s' is not a number", args[i + 1].c_str());
      return 1;
    }
  }
  ros::NodeHandle nh;  // starts the node (ros::Time::now() needs it)
  geometry_msgs::TransformStamped t;
  t.header.stamp = ros::Time::now();
  t.header.frame_id = args[7];
  t.child_frame_id = args[8];
  t.transform.translation.x = v[0];
  t.transform.translation.y = v[1];
  t.transform.translation.z = v[2];
  tf2::Quaternion q;
  q.setRPY(v[5], v[4], v[3]);
  t.transform.rotation.x = q.x();
  t.transform.rotation.y = q.y();
  t.transform.rotation.z = q.z();
  t.transform.rotation.w = q.w();
  tf2_ros::StaticTransformBroadcaster broadcaster;
  broadcaster.sendTransform(t);
  ros::spin();
  return 0;
}
