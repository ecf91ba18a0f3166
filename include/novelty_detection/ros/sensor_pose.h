// The pose of the sensor that took a sweep, from tf, for stamps tf has not reached yet.
//
// A sweep is stamped when its last line arrives; the sensor's transform (a tilting laser's
// joint) is often published only up to the previous line, and a bag that ends with the
// sweep never publishes a later one: an exact lookup then fails with "would require
// extrapolation into the future" and the sweep would lose its viewpoint. So: wait a little
// (wall clock: a paused simulated clock must not stop the caller) for the exact transform,
// then take the latest one tf has, when it is at most `tolerance_s` older than the stamp.
#pragma once

#include <ros/time.h>
#include <tf2_ros/buffer.h>
#include <Eigen/Geometry>

#include <string>

namespace novelty_detection {

struct SensorPose {
  Eigen::Isometry3d T_fixed_sensor = Eigen::Isometry3d::Identity();
  bool exact = true;   ///< at the stamp itself (else: the latest, `age_s` older)
  double age_s = 0.0;  ///< stamp minus the transform's stamp [s]
};

/// T_fixed_sensor at `stamp`, waiting up to `wait_s` wall seconds for it, else the latest
/// transform when it is at most `tolerance_s` older than `stamp`. Throws
/// tf2::TransformException (with the reason) when neither exists.
SensorPose lookupSensorPose(const tf2_ros::Buffer& buffer, const std::string& fixed_frame,
                            const std::string& sensor_frame, const ros::Time& stamp, double wait_s,
                            double tolerance_s);

}  // namespace novelty_detection
