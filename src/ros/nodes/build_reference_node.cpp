// build_reference: accumulates PointCloud2 sweeps (e.g. from a bag played with --clock) in
// the fixed frame into one reference map and saves it atomically as a PCD file.
//
//   ~input          sweeps (any PointCloud2 with float x, y, z)
//   ~fixed_frame    frame of the map (default "map")
//   ~output_file    destination .pcd (required)
//   ~voxel_size_m   keeps one point per voxel of this edge (default 0.02; 0 keeps all)
//   ~idle_timeout   saves and exits this many wall seconds after the last sweep (default 5)
#include <pcl/filters/voxel_grid.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/message_filter.h>
#include <tf2_ros/transform_listener.h>

#include <cmath>
#include <exception>
#include <mutex>

#include "novelty_detection/io/cloud_io.h"
#include "novelty_detection/ros/conversions.h"

using novelty_detection::Cloud;

int main(int argc, char** argv) {
  ros::init(argc, argv, "build_reference");
  ros::NodeHandle nh, pnh("~");
  std::string fixed_frame = pnh.param<std::string>("fixed_frame", "map");
  std::string output_file = pnh.param<std::string>("output_file", "");
  const double voxel = pnh.param("voxel_size_m", 0.02);
  const double idle_timeout = pnh.param("idle_timeout", 5.0);
  if (output_file.empty() || !(voxel >= 0.0) || !(idle_timeout > 0.0)) {
    ROS_FATAL("build_reference: set ~output_file, ~voxel_size_m >= 0 and ~idle_timeout > 0");
    return 1;
  }
  tf2_ros::Buffer buffer;
  tf2_ros::TransformListener listener(buffer, nh);
  std::mutex mutex;
  Cloud map;
  int sweeps = 0;
  ros::WallTime last_sweep;
  tf2_ros::MessageFilter<sensor_msgs::PointCloud2> filter(buffer, fixed_frame, 20, nh);
  filter.registerCallback([&](const sensor_msgs::PointCloud2::ConstPtr& msg) {
    try {
      Cloud cloud = novelty_detection::fromPointCloud2(*msg);
      const Eigen::Isometry3f T =
          tf2::transformToEigen(
              buffer.lookupTransform(fixed_frame, msg->header.frame_id, msg->header.stamp))
              .cast<float>();
      std::lock_guard<std::mutex> lock(mutex);
      for (auto p : cloud) {
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
        p.getVector3fMap() = T * p.getVector3fMap();
        map.push_back(p);
      }
      ++sweeps;
      last_sweep = ros::WallTime::now();
      ROS_INFO("build_reference: sweep %d, map has %zu points", sweeps, map.size());
    } catch (const std::exception& e) {
      ROS_WARN("build_reference: sweep skipped: %s", e.what());
    }
  });
  ros::Subscriber sub = pnh.subscribe<sensor_msgs::PointCloud2>(
      "input", 10, [&](const sensor_msgs::PointCloud2::ConstPtr& msg) { filter.add(msg); });
  ros::AsyncSpinner spinner(1);
  spinner.start();
  ROS_INFO("build_reference: accumulating %s in '%s' into %s", sub.getTopic().c_str(),
           fixed_frame.c_str(), output_file.c_str());
  while (ros::ok()) {
    ros::WallDuration(0.2).sleep();
    std::lock_guard<std::mutex> lock(mutex);
    if (sweeps > 0 && (ros::WallTime::now() - last_sweep).toSec() > idle_timeout) break;
  }
  spinner.stop();
  std::lock_guard<std::mutex> lock(mutex);
  if (map.empty()) {
    ROS_ERROR("build_reference: no sweep received, nothing saved");
    return 1;
  }
  Cloud out;
  if (voxel > 0.0) {
    pcl::VoxelGrid<novelty_detection::PointT> grid;
    grid.setInputCloud(map.makeShared());
    grid.setLeafSize(voxel, voxel, voxel);
    grid.filter(out);
  } else {
    out = map;
  }
  try {
    novelty_detection::saveCloudAtomic(output_file, out);
  } catch (const std::exception& e) {
    ROS_ERROR("build_reference: %s", e.what());
    return 1;
  }
  ROS_INFO("build_reference: saved %zu points from %d sweeps to %s", out.size(), sweeps,
           output_file.c_str());
  return 0;
}
