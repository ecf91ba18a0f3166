// build_reference: collects PointCloud2 sweeps (e.g. from a bag played with --clock) in the
// fixed frame, each with the pose of the sensor that took it, and saves them as a
// reference (io/reference_sweeps.h) once the sweeps stop:
//
//   ~input          sweeps (any PointCloud2 with float x, y, z)
//   ~fixed_frame    frame of the map (default "map")
//   ~sensor_frame   frame of the sensor (default "": the sweep's own frame)
//   ~output_file    a directory (default $ROS_HOME/novelty_detection/reference): one PCD
//                   per sweep, VIEWPOINT = its sensor pose; or a .pcd file: the sweeps
//                   merged (its VIEWPOINT the sensor pose when there is one sweep)
//   ~voxel_size_m   keeps one point per voxel of this edge in each sweep (default 0: all)
//   ~max_sweeps     saves after this many sweeps (default 0: when they stop)
//   ~idle_timeout   saves this many wall seconds after the last sweep, kept or skipped
//                   (default 5)
//   ~pose_tolerance_s  the sensor pose may be the latest tf has, this much older than
//                   the sweep (default 0.5; a tilting laser's last line)
//
// Exits 0 once saved; 1 (FATAL) on invalid parameters, when no usable sweep arrived, or
// when the save fails: nothing is lost silently.
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/message_filter.h>
#include <tf2_ros/transform_listener.h>

#include <cmath>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include "novelty_detection/error_text.h"
#include "novelty_detection/io/cloud_io.h"
#include "novelty_detection/io/reference_sweeps.h"
#include "novelty_detection/preprocess/input_check.h"
#include "novelty_detection/preprocess/voxel_filter.h"
#include "novelty_detection/ros/conversions.h"
#include "novelty_detection/ros/sensor_pose.h"

namespace nd = novelty_detection;

namespace {

std::string rosHome() {
  if (const char* h = std::getenv("ROS_HOME"); h && *h) return h;
  if (const char* h = std::getenv("HOME"); h && *h) return std::string(h) + "/.ros";
  return ".";
}

/// Saves the sweeps as a directory or as one merged file; returns what was written.
std::string save(const std::string& output, const std::vector<nd::CloudFile>& sweeps) {
  std::size_t points = 0;
  for (const auto& s : sweeps) points += s.cloud.size();
  // The folders above the output are made as needed (the default lies under ROS_HOME).
  const std::filesystem::path parent = std::filesystem::path(output).parent_path();
  std::error_code ec;
  if (!parent.empty()) std::filesystem::create_directories(parent, ec);
  if (ec) throw std::runtime_error("cannot create '" + parent.string() + "': " + ec.message());
  if (!nd::hasPcdExtension(output)) {
    nd::saveReferenceSweeps(output, sweeps);
    return std::to_string(sweeps.size()) + " sweeps (" + std::to_string(points) +
           " points) with their viewpoints into " + output + "/";
  }
  nd::Cloud merged;
  for (const auto& s : sweeps) merged += s.cloud;
  const bool one = sweeps.size() == 1;
  if (!one) {
    ROS_WARN(
        "build_reference: %zu sweeps merged into one file keep no viewpoint: the "
        "visibility rules and disappearances will be off against it; give a directory "
        "as ~output_file to keep each sweep's pose",
        sweeps.size());
  }
  nd::saveCloudAtomic(output, merged,
                      one ? sweeps[0].T_frame_sensor : Eigen::Isometry3d::Identity());
  return std::to_string(points) + " points from " + std::to_string(sweeps.size()) +
         " sweeps into " + output + (one ? " (VIEWPOINT: the sensor pose)" : "");
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "build_reference");
  ros::NodeHandle nh, pnh("~");
  const std::string fixed_frame = pnh.param<std::string>("fixed_frame", "map");
  const std::string sensor_frame_param = pnh.param<std::string>("sensor_frame", "");
  std::string output = pnh.param<std::string>("output_file", "");
  if (output.empty()) output = rosHome() + "/novelty_detection/reference";
  const double voxel = pnh.param("voxel_size_m", 0.0);
  const int max_sweeps = pnh.param("max_sweeps", 0);
  const double idle_timeout = pnh.param("idle_timeout", 5.0);
  const double pose_tolerance = pnh.param("pose_tolerance_s", 0.5);
  if (!(voxel == 0.0 || (voxel >= 1e-3 && std::isfinite(voxel))) || max_sweeps < 0 ||
      !(idle_timeout > 0.0) || !(pose_tolerance >= 0.0) || fixed_frame.empty()) {
    ROS_FATAL(
        "build_reference: invalid parameters: need ~voxel_size_m 0 or >= 0.001, "
        "~max_sweeps >= 0, ~idle_timeout > 0, ~pose_tolerance_s >= 0 and a ~fixed_frame");
    return 1;
  }
  if (!nd::hasPcdExtension(output) && nd::isDirectory(output)) {
    ROS_INFO("build_reference: %s exists; it is replaced only if it holds only sweep_*.pcd",
             output.c_str());
  }
  tf2_ros::Buffer buffer;
  tf2_ros::TransformListener listener(buffer, nh);
  std::mutex mutex;
  std::vector<nd::CloudFile> sweeps;
  std::size_t points = 0, skipped = 0;
  ros::WallTime last_sweep;  // the last sweep received, kept or skipped
  tf2_ros::MessageFilter<sensor_msgs::PointCloud2> filter(buffer, fixed_frame, 20, nh);
  filter.registerCallback([&](const sensor_msgs::PointCloud2::ConstPtr& msg) {
    try {
      const std::string sensor_frame =
          sensor_frame_param.empty() ? msg->header.frame_id : sensor_frame_param;
      if (sensor_frame == fixed_frame) {
        throw std::runtime_error("the sweep is in '" + fixed_frame +
                                 "' and ~sensor_frame is not set: the sensor's pose is unknown");
      }
      nd::Cloud cloud = nd::fromPointCloud2(*msg);
      const Eigen::Isometry3f T_fixed_cloud =
          nd::lookupSensorPose(buffer, fixed_frame, msg->header.frame_id, msg->header.stamp, 0.3,
                               pose_tolerance)
              .T_fixed_sensor.cast<float>();
      const nd::SensorPose pose = nd::lookupSensorPose(buffer, fixed_frame, sensor_frame,
                                                       msg->header.stamp, 0.3, pose_tolerance);
      nd::CloudFile sweep;
      sweep.T_frame_sensor = pose.T_fixed_sensor;
      sweep.cloud.reserve(cloud.size());
      for (auto p : cloud) {
        if (!nd::usablePoint(p)) continue;
        p.getVector3fMap() = T_fixed_cloud * p.getVector3fMap();
        sweep.cloud.push_back(p);
      }
      if (voxel > 0.0) sweep.cloud = nd::voxelDownsample(sweep.cloud, voxel);
      if (sweep.cloud.empty()) throw std::runtime_error("no finite point");
      std::lock_guard<std::mutex> lock(mutex);
      if (max_sweeps > 0 && static_cast<int>(sweeps.size()) >= max_sweeps) return;
      points += sweep.cloud.size();
      sweeps.push_back(std::move(sweep));
      last_sweep = ros::WallTime::now();
      const Eigen::Vector3d o = pose.T_fixed_sensor.translation();
      ROS_INFO(
          "build_reference: sweep %zu: %zu points, sensor at (%.2f, %.2f, %.2f)%s; %zu "
          "points in all",
          sweeps.size(), sweeps.back().cloud.size(), o.x(), o.y(), o.z(),
          pose.exact ? "" : " (latest tf pose)", points);
    } catch (const std::exception& e) {
      std::lock_guard<std::mutex> lock(mutex);
      ++skipped;
      last_sweep = ros::WallTime::now();
      ROS_ERROR("build_reference: sweep skipped: %s", nd::errorText(e).c_str());
    }
  });
  ros::Subscriber sub = pnh.subscribe<sensor_msgs::PointCloud2>(
      "input", 10, [&](const sensor_msgs::PointCloud2::ConstPtr& msg) { filter.add(msg); });
  ros::AsyncSpinner spinner(1);
  spinner.start();
  ROS_INFO("build_reference: collecting %s in '%s' into %s", sub.getTopic().c_str(),
           fixed_frame.c_str(), output.c_str());
  while (ros::ok()) {
    ros::WallDuration(0.1).sleep();
    std::lock_guard<std::mutex> lock(mutex);
    if (max_sweeps > 0 && static_cast<int>(sweeps.size()) >= max_sweeps) break;
    if ((!sweeps.empty() || skipped > 0) &&
        (ros::WallTime::now() - last_sweep).toSec() > idle_timeout)
      break;
  }
  spinner.stop();
  std::lock_guard<std::mutex> lock(mutex);
  if (sweeps.empty()) {
    ROS_FATAL("build_reference: no usable sweep received (%zu skipped), nothing saved", skipped);
    return 1;
  }
  try {
    const std::string what = save(output, sweeps);
    ROS_INFO("build_reference: saved %s", what.c_str());
  } catch (const std::exception& e) {
    ROS_FATAL("build_reference: the reference was NOT saved: %s", nd::errorText(e).c_str());
    return 1;
  }
  return 0;
}
