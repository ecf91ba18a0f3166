#include "novelty_detection/sim/laser.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace novelty_detection {
namespace sim {
namespace {
constexpr double kDeg = M_PI / 180.0;
}

int LaserConfig::beamsPerLine() const {
  return static_cast<int>(std::lround(fov_deg / step_deg)) + 1;
}

double LaserConfig::tiltAt(int line) const {
  if (lines <= 1) return 0.5 * (tilt_min_deg + tilt_max_deg) * kDeg;
  return (tilt_min_deg + (tilt_max_deg - tilt_min_deg) * line / (lines - 1)) * kDeg;
}

double LaserConfig::beamAngle(int beam) const { return (-0.5 * fov_deg + beam * step_deg) * kDeg; }

void LaserConfig::validate() const {
  auto fail = [](const std::string& m) { throw std::invalid_argument("LaserConfig: " + m); };
  if (!(fov_deg > 0 && fov_deg <= 360)) fail("fov_deg must lie in (0, 360]");
  if (!(step_deg > 0 && step_deg <= fov_deg)) fail("step_deg must lie in (0, fov_deg]");
  if (lines < 1 || lines > 10000) fail("lines must lie in [1, 10000]");
  if (!(tilt_min_deg >= -90 && tilt_max_deg <= 90 && tilt_min_deg <= tilt_max_deg))
    fail("tilt range must satisfy -90 <= tilt_min_deg <= tilt_max_deg <= 90");
  if (!(min_range_m >= 0 && max_range_m > min_range_m))
    fail("ranges must satisfy 0 <= min_range_m < max_range_m");
  if (!(mount_height_m > 0)) fail("mount_height_m must be positive");
  if (!(noise_variance_m2 >= 0 && noise_variance_m2 < 1))
    fail("noise_variance_m2 must lie in [0, 1)");
}

Eigen::Isometry3d sensorPose(double x, double y, double yaw_rad, double mount_height_m) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, y, mount_height_m);
  T.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}

Eigen::Isometry3d baseToLaser(double tilt_rad, double mount_height_m) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(0, 0, mount_height_m);
  T.linear() = Eigen::AngleAxisd(tilt_rad, Eigen::Vector3d::UnitY()).toRotationMatrix();
  return T;
}

Eigen::Vector3d beamDirection(double azimuth_rad, double tilt_rad) {
  return Eigen::AngleAxisd(tilt_rad, Eigen::Vector3d::UnitY()) *
         Eigen::Vector3d(std::cos(azimuth_rad), std::sin(azimuth_rad), 0.0);
}

LaserLine simulateTiltLine(const World& world, const Eigen::Isometry3d& T_world_sensor,
                           const LaserConfig& config, double tilt_rad, Rng& rng) {
  config.validate();
  const int n = config.beamsPerLine();
  const double sigma = std::sqrt(config.noise_variance_m2);
  LaserLine line;
  line.tilt_rad = tilt_rad;
  line.ranges.assign(n, std::numeric_limits<float>::infinity());
  line.object_ids.assign(n, -1);
  line.true_ranges.assign(n, std::numeric_limits<double>::infinity());
  Ray ray;
  ray.origin = T_world_sensor.translation();
  for (int i = 0; i < n; ++i) {
    ray.dir = T_world_sensor.linear() * beamDirection(config.beamAngle(i), tilt_rad);
    const auto hit = world.intersect(ray, config.max_range_m);
    if (!hit) continue;
    // Zero-mean Gaussian noise along the beam (paper Sec. V: variance 0.001).
    const double r = sigma > 0 ? hit->t + sigma * standardNormal(rng) : hit->t;
    if (r < config.min_range_m || r > config.max_range_m) continue;
    line.ranges[i] = static_cast<float>(r);
    line.object_ids[i] = hit->object_id;
    line.true_ranges[i] = hit->t;
  }
  return line;
}

TiltScan simulateTiltScan(const World& world, const Eigen::Isometry3d& T_world_sensor,
                          const LaserConfig& config, std::uint64_t noise_seed) {
  config.validate();
  Rng rng(noise_seed);
  TiltScan scan;
  scan.T_world_sensor = T_world_sensor;
  const int n = config.beamsPerLine();
  scan.lines.reserve(config.lines);
  for (int l = 0; l < config.lines; ++l) {
    scan.lines.push_back(simulateTiltLine(world, T_world_sensor, config, config.tiltAt(l), rng));
    const LaserLine& line = scan.lines.back();
    for (int i = 0; i < n; ++i) {
      if (line.object_ids[i] < 0) continue;
      const Eigen::Vector3d dir = beamDirection(config.beamAngle(i), line.tilt_rad);
      const Eigen::Vector3d p = T_world_sensor * (static_cast<double>(line.ranges[i]) * dir);
      scan.true_points.push_back(T_world_sensor * (line.true_ranges[i] * dir));
      scan.cloud.push_back(
          PointT(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
      scan.labels.push_back(line.object_ids[i]);
    }
  }
  scan.cloud.width = static_cast<std::uint32_t>(scan.cloud.size());
  scan.cloud.height = 1;
  scan.cloud.is_dense = true;
  scan.cloud.sensor_origin_ << T_world_sensor.translation().cast<float>(), 0.0f;
  scan.cloud.sensor_orientation_ = Eigen::Quaternionf(T_world_sensor.linear().cast<float>());
  return scan;
}

}  // namespace sim
}  // namespace novelty_detection
