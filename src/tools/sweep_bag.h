// rosbag output of simulate_scans: the raw lines of a tilting-laser sweep as LaserScan with
// the robot's pose and the tilt joint on /tf, and each sweep as one PointCloud2 in the map
// frame. Private to the tool.
#pragma once

#include <geometry_msgs/TransformStamped.h>
#include <rosbag/bag.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_msgs/TFMessage.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "novelty_detection/sim/laser.h"

namespace novelty_detection {
namespace sweep_bag {

constexpr double kDeg = M_PI / 180.0;

inline geometry_msgs::TransformStamped transformMsg(const Eigen::Isometry3d& T,
                                                    const ros::Time& stamp,
                                                    const std::string& parent,
                                                    const std::string& child) {
  geometry_msgs::TransformStamped m;
  m.header.stamp = stamp;
  m.header.frame_id = parent;
  m.child_frame_id = child;
  m.transform.translation.x = T.translation().x();
  m.transform.translation.y = T.translation().y();
  m.transform.translation.z = T.translation().z();
  const Eigen::Quaterniond q(T.linear());
  m.transform.rotation.x = q.x();
  m.transform.rotation.y = q.y();
  m.transform.rotation.z = q.z();
  m.transform.rotation.w = q.w();
  return m;
}

inline sensor_msgs::PointCloud2 cloudMsg(const Cloud& cloud, const ros::Time& stamp) {
  sensor_msgs::PointCloud2 m;
  m.header.stamp = stamp;
  m.header.frame_id = "map";
  m.height = 1;
  m.width = static_cast<std::uint32_t>(cloud.size());
  const char* names[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) {
    sensor_msgs::PointField f;
    f.name = names[k];
    f.offset = 4 * k;
    f.datatype = sensor_msgs::PointField::FLOAT32;
    f.count = 1;
    m.fields.push_back(f);
  }
  m.is_bigendian = false;
  m.point_step = 12;
  m.row_step = 12 * m.width;
  m.is_dense = true;
  m.data.resize(m.row_step);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const float xyz[3] = {cloud[i].x, cloud[i].y, cloud[i].z};
    std::memcpy(&m.data[12 * i], xyz, sizeof(xyz));
  }
  return m;
}

inline Eigen::Isometry3d basePose(const Eigen::Vector3d& base) {
  Eigen::Isometry3d T_map_base = Eigen::Isometry3d::Identity();
  T_map_base.translation() = Eigen::Vector3d(base.x(), base.y(), 0.0);
  T_map_base.linear() = Eigen::AngleAxisd(base.z(), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T_map_base;
}

// T_map_base is the pose the robot reports (with the localisation error, if any).
inline void writeSweep(rosbag::Bag& bag, const sim::LaserConfig& laser,
                       const std::vector<sim::LaserLine>& lines,
                       const Eigen::Isometry3d& T_map_base, const Cloud& cloud, double t0,
                       double dt) {
  const auto write_tf = [&](const ros::Time& stamp, double tilt_rad) {
    tf2_msgs::TFMessage tf;
    tf.transforms.push_back(transformMsg(T_map_base, stamp, "map", "base_link"));
    tf.transforms.push_back(transformMsg(sim::baseToLaser(tilt_rad, laser.mount_height_m), stamp,
                                         "base_link", "laser"));
    bag.write("/tf", stamp, tf);
  };
  for (std::size_t l = 0; l < lines.size(); ++l) {
    const ros::Time stamp(t0 + dt * l);
    write_tf(stamp, lines[l].tilt_rad);
    sensor_msgs::LaserScan scan;
    scan.header.stamp = stamp;
    scan.header.frame_id = "laser";
    scan.angle_min = static_cast<float>(laser.beamAngle(0));
    scan.angle_max = static_cast<float>(laser.beamAngle(laser.beamsPerLine() - 1));
    scan.angle_increment = static_cast<float>(laser.step_deg * kDeg);
    scan.scan_time = 0.025f;  // UTM-30LX: 40 Hz
    scan.time_increment = static_cast<float>(0.025 / (360.0 / laser.step_deg));
    scan.range_min = static_cast<float>(laser.min_range_m);
    scan.range_max = static_cast<float>(laser.max_range_m);
    scan.ranges = lines[l].ranges;  // +inf: no return (REP 117)
    bag.write("/scan", stamp, scan);
  }
  const ros::Time end(t0 + dt * lines.size());
  // The joint's state keeps streaming, as on a robot: one more at the sweep's stamp, so that a
  // reader looking up the laser's pose at that stamp finds it without waiting.
  if (!lines.empty()) write_tf(end, lines.back().tilt_rad);
  bag.write("/sweep", end, cloudMsg(cloud, end));
}

}  // namespace sweep_bag
}  // namespace novelty_detection
