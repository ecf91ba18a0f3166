#include "novelty_detection/preprocess/up_direction.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace novelty_detection {
namespace {

constexpr std::size_t kSamplePoints = 20000;
constexpr int kPlanes = 5;
constexpr int kIterations = 300;
constexpr double kMaxBeneath = 0.05;
constexpr double kMinShare = 0.05;
const double kCosMaxAngle = std::cos(45.0 * M_PI / 180.0);

struct Plane {
  Eigen::Vector3d normal;
  double d = 0.0;
  std::vector<std::size_t> inliers;  ///< into the sample
};

/// The plane through most of `active` points of `pts` (RANSAC), or none.
bool bestPlane(const std::vector<Eigen::Vector3d>& pts, const std::vector<std::size_t>& active,
               double t, std::mt19937_64& rng, Plane* out) {
  if (active.size() < 3) return false;
  std::uniform_int_distribution<std::size_t> pick(0, active.size() - 1);
  std::size_t best = 0;
  for (int it = 0; it < kIterations; ++it) {
    const Eigen::Vector3d& a = pts[active[pick(rng)]];
    const Eigen::Vector3d& b = pts[active[pick(rng)]];
    const Eigen::Vector3d& c = pts[active[pick(rng)]];
    Eigen::Vector3d n = (b - a).cross(c - a);
    if (n.norm() < 1e-12) continue;
    n.normalize();
    const double d = -n.dot(a);
    std::size_t support = 0;
    for (std::size_t i : active) support += std::abs(n.dot(pts[i]) + d) <= t;
    if (support > best) {
      best = support;
      out->normal = n;
      out->d = d;
    }
  }
  if (best < 3) return false;
  out->inliers.clear();
  for (std::size_t i : active)
    if (std::abs(out->normal.dot(pts[i]) + out->d) <= t) out->inliers.push_back(i);
  return true;
}

}  // namespace

UpSetting parseUp(const std::string& text) {
  UpSetting s;
  if (text == "auto") {
    s.automatic = true;
    return s;
  }
  std::istringstream in(text);
  Eigen::Vector3d v;
  std::string rest;
  if (!(in >> v.x() >> v.y() >> v.z()) || (in >> rest) || !v.allFinite() || v.norm() < 1e-9) {
    throw std::invalid_argument("parameter preprocess/up = '" + text +
                                "' must be 'auto' or three numbers, not all zero (e.g. '0 0 1')");
  }
  s.vector = v.normalized();
  return s;
}

UpEstimate resolveUp(const UpSetting& setting, const Cloud& cloud) {
  UpEstimate e;
  if (!setting.automatic) {
    e.up = setting.vector;
    return e;
  }
  e.source = "nominal";
  std::vector<Eigen::Vector3d> pts;
  std::size_t finite = 0;
  for (const auto& p : cloud)
    finite += std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
  const std::size_t stride = std::max<std::size_t>(1, finite / kSamplePoints);
  std::size_t k = 0;
  for (const auto& p : cloud) {
    if (!(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))) continue;
    if (k++ % stride == 0) pts.emplace_back(p.x, p.y, p.z);
  }
  if (pts.size() < 10) return e;
  const bool has_origin = sensorOriginKnown(cloud.sensor_origin_);
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const auto& p : pts) centre += p;
  centre /= static_cast<double>(pts.size());
  const Eigen::Vector3d origin =
      has_origin ? cloud.sensor_origin_.head<3>().cast<double>() : centre;
  std::vector<double> ranges;
  ranges.reserve(pts.size());
  for (const auto& p : pts) ranges.push_back((p - origin).norm());
  std::nth_element(ranges.begin(), ranges.begin() + ranges.size() / 2, ranges.end());
  const double t = std::clamp(0.02 * ranges[ranges.size() / 2], 0.01, 0.1);

  std::vector<Eigen::Vector3d> nominal{Eigen::Vector3d::UnitZ()};
  if (cloud.height > 1) nominal.push_back(-Eigen::Vector3d::UnitY());
  std::mt19937_64 rng(20240611);
  std::vector<std::size_t> active(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) active[i] = i;
  std::size_t best_support = 0;
  for (int round = 0; round < kPlanes; ++round) {
    Plane plane;
    if (!bestPlane(pts, active, t, rng, &plane)) break;
    const double share = static_cast<double>(plane.inliers.size()) / pts.size();
    if (share < kMinShare) break;
    // Orient the normal towards the sensor (towards most points without an origin).
    std::size_t above = 0, beneath = 0;
    for (const auto& p : pts) {
      const double s = plane.normal.dot(p) + plane.d;
      above += s > 3 * t;
      beneath += s < -3 * t;
    }
    bool flip = has_origin ? plane.normal.dot(origin) + plane.d < 0 : beneath > above;
    if (flip) {
      plane.normal = -plane.normal;
      plane.d = -plane.d;
      std::swap(above, beneath);
    }
    const bool sensor_above = !has_origin || plane.normal.dot(origin) + plane.d > t;
    bool near_nominal = false;
    for (const auto& n : nominal) near_nominal |= plane.normal.dot(n) >= kCosMaxAngle;
    if (sensor_above && near_nominal && beneath <= kMaxBeneath * pts.size() &&
        plane.inliers.size() > best_support) {
      best_support = plane.inliers.size();
      e.up = plane.normal;
      e.source = "plane";
      e.plane_share = share;
    }
    // Next round without this plane's points.
    std::vector<char> on(pts.size(), 0);
    for (std::size_t i : plane.inliers) on[i] = 1;
    std::vector<std::size_t> next;
    for (std::size_t i : active)
      if (!on[i]) next.push_back(i);
    active.swap(next);
  }
  return e;
}

Eigen::Matrix3d rotationToZUp(const Eigen::Vector3d& up) {
  return Eigen::Quaterniond::FromTwoVectors(up.normalized(), Eigen::Vector3d::UnitZ())
      .toRotationMatrix();
}

}  // namespace novelty_detection
