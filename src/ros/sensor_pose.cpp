#include "novelty_detection/ros/sensor_pose.h"

#include <tf2_eigen/tf2_eigen.h>

#include <chrono>
#include <cmath>
#include <thread>

namespace novelty_detection {

SensorPose lookupSensorPose(const tf2_ros::Buffer& buffer, const std::string& fixed_frame,
                            const std::string& sensor_frame, const ros::Time& stamp, double wait_s,
                            double tolerance_s) {
  const auto give_up =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(std::max(0.0, wait_s));
  while (!buffer.canTransform(fixed_frame, sensor_frame, stamp) &&
         std::chrono::steady_clock::now() < give_up)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  SensorPose pose;
  try {
    pose.T_fixed_sensor =
        tf2::transformToEigen(buffer.lookupTransform(fixed_frame, sensor_frame, stamp));
    return pose;
  } catch (const tf2::TransformException& exact_error) {
    // The latest transform, if it is recent enough.
    geometry_msgs::TransformStamped latest;
    try {
      latest = buffer.lookupTransform(fixed_frame, sensor_frame, ros::Time(0));
    } catch (const tf2::TransformException&) {
      throw exact_error;
    }
    const double age = (stamp - latest.header.stamp).toSec();
    if (!(std::abs(age) <= tolerance_s)) throw exact_error;
    pose.T_fixed_sensor = tf2::transformToEigen(latest);
    pose.exact = false;
    pose.age_s = age;
    return pose;
  }
}

}  // namespace novelty_detection
