// Helpers shared by the rostest nodes: synthetic sweeps and waiting with wall-clock limits.
#pragma once

#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>

#include <functional>
#include <random>
#include <string>

#include "novelty_detection/ros/conversions.h"

namespace test_helpers {

/// Spins until pred() or the wall-clock timeout; returns pred().
inline bool waitFor(const std::function<bool()>& pred, double timeout_s) {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
  while (ros::ok() && !pred() && ros::WallTime::now() < deadline) {
    ros::spinOnce();
    ros::WallDuration(0.01).sleep();
  }
  return pred();
}

/// A corridor 6 m x 3 m x 2 m (floor and two walls) sampled on a grid with seeded noise,
/// optionally with a 0.4 m cube standing on the floor at (3, 0): its three visible faces.
/// Returns the number of cube points through `cube_points` when given.
inline novelty_detection::Cloud corridor(bool with_cube, unsigned seed,
                                         std::size_t* cube_points = nullptr) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, 0.003f);
  novelty_detection::Cloud c;
  const float step = 0.1f;
  for (float x = 0.0f; x < 6.0f; x += step) {
    for (float y = -1.5f; y <= 1.5f; y += step) c.push_back({x, y, noise(rng)});
    for (float z = 0.0f; z < 2.0f; z += step) {
      c.push_back({x, -1.5f + noise(rng), z});
      c.push_back({x, 1.5f + noise(rng), z});
    }
  }
  std::size_t n = 0;
  if (with_cube) {
    const float s = 0.02f;  // denser than the room, as a near object would be
    for (float u = -0.2f; u <= 0.2f; u += s) {
      for (float v = 0.0f; v <= 0.4f; v += s) {
        c.push_back({2.8f + noise(rng), u, v});  // face towards the sensor (x = 2.8)
        ++n;
      }
      for (float w = 2.8f; w <= 3.2f; w += s) {
        c.push_back({w, u, 0.4f + noise(rng)});  // top
        ++n;
      }
    }
  }
  if (cube_points) *cube_points = n;
  c.width = static_cast<std::uint32_t>(c.size());
  c.height = 1;
  return c;
}

inline sensor_msgs::PointCloud2 toMsg(const novelty_detection::Cloud& c, const std::string& frame,
                                      const ros::Time& stamp) {
  std_msgs::Header h;
  h.frame_id = frame;
  h.stamp = stamp;
  return novelty_detection::toPointCloud2(c, h);
}

}  // namespace test_helpers
