// A tilting 2D laser scanner (a Hokuyo UTM-30LX on a tilt unit), ray-cast in a World.
// ROS-free.
//
// Frames: the robot base (base_link) stands on the floor at (x, y, yaw). The tilt axis is the
// base's y axis at mount height; the laser's scan plane is its x-y plane, rotated about y by
// the tilt angle (positive tilt looks down in front, up behind). The "sensor" frame of a sweep
// is the laser frame at zero tilt: T_world_sensor = T_world_base * Translation(0, 0, h); all
// beams of a sweep start at its origin (the PCD VIEWPOINT).
#pragma once

#include <Eigen/Geometry>

#include <cstdint>
#include <vector>

#include "novelty_detection/sim/random.h"
#include "novelty_detection/sim/world.h"
#include "novelty_detection/types.h"

namespace novelty_detection {
namespace sim {

struct LaserConfig {
  double fov_deg = 270.0;            ///< field of view of one line, centred on the laser x axis
  double step_deg = 0.25;            ///< angular step: 1081 beams for 270 deg
  int lines = 28;                    ///< tilt lines per sweep (28 x 1081 = 30,268 beams)
  double tilt_min_deg = -30.0;       ///< first tilt angle (negative looks up in front)
  double tilt_max_deg = 45.0;        ///< last tilt angle
  double min_range_m = 0.1;          ///< returns closer than this are dropped
  double max_range_m = 30.0;         ///< misses and returns beyond this are dropped
  double mount_height_m = 0.6;       ///< height of the tilt axis above the floor
  double noise_variance_m2 = 0.001;  ///< variance of the zero-mean Gaussian range noise

  int beamsPerLine() const;          ///< round(fov / step) + 1
  double tiltAt(int line) const;     ///< tilt angle of a line [rad]
  double beamAngle(int beam) const;  ///< azimuth of a beam in the laser frame [rad]
  /// Throws std::invalid_argument naming the bad field.
  void validate() const;
};

/// One line of the tilting laser, as a LaserScan would carry it.
struct LaserLine {
  double tilt_rad = 0.0;
  std::vector<float> ranges;        ///< per beam [m]; +inf when there is no return
  std::vector<int> object_ids;      ///< per beam; -1 when there is no return
  std::vector<double> true_ranges;  ///< per beam: the noise-free range of a return, else +inf
};

/// A whole sweep: its lines, and the assembled cloud in the world frame.
struct TiltScan {
  Eigen::Isometry3d T_world_sensor = Eigen::Isometry3d::Identity();
  std::vector<LaserLine> lines;
  Cloud cloud;                               ///< returns in line-major, beam order, world frame
  std::vector<int> labels;                   ///< object id per point of cloud (0 static)
  std::vector<Eigen::Vector3d> true_points;  ///< noise-free hit per point of cloud, world frame
};

/// Pose of the sensor (laser at zero tilt) for a robot base at (x, y, yaw) on the floor.
Eigen::Isometry3d sensorPose(double x, double y, double yaw_rad, double mount_height_m);
/// base_link -> laser for a tilt angle (the tilt joint), mount height included.
Eigen::Isometry3d baseToLaser(double tilt_rad, double mount_height_m);
/// Unit beam direction in the sensor frame for an azimuth and a tilt.
Eigen::Vector3d beamDirection(double azimuth_rad, double tilt_rad);

/// Casts one tilt line. Noise (if the variance is > 0) is drawn from `rng`, one normal per
/// return, in beam order.
LaserLine simulateTiltLine(const World& world, const Eigen::Isometry3d& T_world_sensor,
                           const LaserConfig& config, double tilt_rad, Rng& rng);

/// Casts all lines of a sweep; deterministic for a noise seed.
TiltScan simulateTiltScan(const World& world, const Eigen::Isometry3d& T_world_sensor,
                          const LaserConfig& config, std::uint64_t noise_seed);

}  // namespace sim
}  // namespace novelty_detection
