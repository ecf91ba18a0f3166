// Viewpoint robustness scenes: scene groups, the viewpoint suite and the
// newly-visible ground truth.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "novelty_detection/sim/scene.h"

namespace novelty_detection {
namespace sim {
namespace {
constexpr double kDeg = M_PI / 180.0;
}  // namespace

std::string sceneGroup(const SceneConfig& config) {
  if (!config.localisation_error.isZero()) return "localisation_error";
  if (!config.pose_offset.isZero()) return "pose_offset";
  return "same_pose";
}

SceneConfig viewpointSceneConfig(int index, std::uint64_t suite_seed) {
  if (index < 0) throw std::invalid_argument("viewpointSceneConfig: negative index");
  SceneConfig c;
  c.seed = mixSeed(suite_seed, 5000 + static_cast<std::uint64_t>(index));
  Rng rng(mixSeed(c.seed, 6));
  const int group = index % 3, triple = index / 3;
  c.layout = triple % 3 == 2 ? Layout::kOffice : Layout::kCorridor;
  const auto& all = allNoveltyKinds();
  // Appearance kinds cycle over the triples, so each group meets every kind.
  const NoveltyKind first = all[triple % all.size()];
  if (triple % 2 == 1) {
    c.novelty_kinds.push_back(NoveltyKind::kRemovedObject);
    if (uniformInt(rng, 0, 1) == 1) c.novelty_kinds.push_back(first);
  } else {
    c.novelty_kinds.push_back(first);
    if (uniformInt(rng, 0, 1) == 1) c.novelty_kinds.push_back(all[(triple + 3) % all.size()]);
  }
  if (group == 1) {  // the robot came back to roughly, not exactly, the same spot
    const double m = uniform(rng, 0.05, 0.30), dir = uniform(rng, -M_PI, M_PI);
    c.pose_offset =
        Eigen::Vector3d(m * std::cos(dir), m * std::sin(dir), uniform(rng, -10.0, 10.0) * kDeg);
  } else if (group == 2) {  // same spot, but localisation is off by centimetres
    const double m = uniform(rng, 0.01, 0.025), dir = uniform(rng, -M_PI, M_PI);
    const double yaw = uniform(rng, 0.2, 0.8) * (uniformInt(rng, 0, 1) ? 1.0 : -1.0);
    c.localisation_error << m * std::cos(dir), m * std::sin(dir), uniform(rng, -0.01, 0.01),
        uniform(rng, -0.4, 0.4) * kDeg, uniform(rng, -0.4, 0.4) * kDeg, yaw * kDeg;
  }
  return c;
}

std::vector<std::uint8_t> newlyVisibleMask(const World& reference_world,
                                           const Eigen::Isometry3d& T_world_sensor_reference,
                                           const LaserConfig& laser,
                                           const std::vector<Eigen::Vector3d>& points,
                                           const std::vector<int>& labels, double tolerance_m) {
  if (points.size() != labels.size())
    throw std::invalid_argument("newlyVisibleMask: points and labels differ in size");
  if (!(tolerance_m >= 0)) throw std::invalid_argument("newlyVisibleMask: negative tolerance");
  constexpr double kAngleTol = 1e-6;
  const double half_fov = 0.5 * laser.fov_deg * kDeg;
  const double tilt_lo = laser.tilt_min_deg * kDeg - kAngleTol;
  const double tilt_hi = laser.tilt_max_deg * kDeg + kAngleTol;
  const Eigen::Vector3d origin = T_world_sensor_reference.translation();
  const Eigen::Matrix3d R_t = T_world_sensor_reference.linear().transpose();
  // A beam (azimuth a, tilt t) points along (cos a cos t, sin a, -cos a sin t) in the
  // sensor frame (laser.h); a direction has two (a, t) solutions, one per sign of cos a.
  auto inFieldOfView = [&](const Eigen::Vector3d& v) {
    const double n = v.norm();
    const double a = std::asin(std::clamp(v.y() / n, -1.0, 1.0));
    // Along the tilt axis every tilt reaches the direction (and atan2 of two round-off
    // residues would pick an arbitrary one).
    if (std::hypot(v.x(), v.z()) <= 1e-9 * n) return std::abs(a) <= half_fov + kAngleTol;
    const double t_front = std::atan2(-v.z(), v.x());
    if (std::abs(a) <= half_fov + kAngleTol && t_front >= tilt_lo && t_front <= tilt_hi)
      return true;
    const double a_back = (v.y() >= 0 ? M_PI : -M_PI) - a;
    const double t_back = std::atan2(v.z(), -v.x());
    return std::abs(a_back) <= half_fov + kAngleTol && t_back >= tilt_lo && t_back <= tilt_hi;
  };
  std::vector<std::uint8_t> mask(points.size(), 0);
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (labels[i] != 0) continue;
    const Eigen::Vector3d d = points[i] - origin;
    const double dist = d.norm();
    if (!(dist >= laser.min_range_m && dist <= laser.max_range_m) || !inFieldOfView(R_t * d)) {
      mask[i] = 1;
      continue;
    }
    if (dist <= tolerance_m) continue;
    const Ray ray{origin, d / dist};
    if (reference_world.intersect(ray, dist - tolerance_m)) mask[i] = 1;
  }
  return mask;
}

}  // namespace sim
}  // namespace novelty_detection
