// Seeded synthetic scans with exact ground truth, shared by the pre-processing tests and
// benchmarks: a tilting range sensor (270 deg x 100 deg field of view) inside a corridor,
// rays cast against the corridor's faces and axis-aligned boxes on the floor, Gaussian
// noise along each beam (as a laser's range noise), optional sparse outliers and NaNs.
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "novelty_detection/types.h"

namespace novelty_detection {
namespace synthetic {

enum Label : int { kFloor = 0, kRoom = 1, kObject = 2, kOutlier = -1, kNan = -2 };

struct AlignedBox {
  Eigen::Vector3d lo, hi;
};

struct SceneOptions {
  int points = 30000;                ///< rays cast (before outliers and NaNs are added)
  double range_sigma_m = 0.0;        ///< noise along the beam
  double outlier_fraction = 0.0;     ///< sparse outliers added, uniform in the corridor
  double outlier_clearance_m = 0.0;  ///< ... at least this far from every surface
  double nan_fraction = 0.0;         ///< NaN points inserted at random positions
  unsigned seed = 1;
  Eigen::Vector3d sensor = Eigen::Vector3d(0.0, 0.0, 0.6);
  AlignedBox room{Eigen::Vector3d(-3.0, -1.2, 0.0), Eigen::Vector3d(12.0, 1.2, 2.6)};
  /// Objects standing on the floor; by default a 10 cm high box and a 0.5 m cube.
  std::vector<AlignedBox> objects{
      {Eigen::Vector3d(1.5, 0.2, 0.0), Eigen::Vector3d(2.0, 0.7, 0.10)},
      {Eigen::Vector3d(4.0, -1.0, 0.0), Eigen::Vector3d(4.5, -0.5, 0.5)}};
};

struct Scene {
  Cloud cloud;
  std::vector<int> label;         ///< per point: Label, or kObject + object number
  std::vector<double> surface_z;  ///< height of the noise-free hit (NaN for outliers)
};

/// Entry distance of a ray into a box from outside (slab method), +inf when it misses.
inline double rayEnter(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const AlignedBox& b) {
  double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d(a)) < 1e-12) {
      if (o(a) < b.lo(a) || o(a) > b.hi(a)) return std::numeric_limits<double>::infinity();
      continue;
    }
    double ta = (b.lo(a) - o(a)) / d(a), tb = (b.hi(a) - o(a)) / d(a);
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return t0 <= t1 && t0 > 0.0 ? t0 : std::numeric_limits<double>::infinity();
}

inline Scene makeCorridor(const SceneOptions& opt) {
  std::mt19937 rng(opt.seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  Scene scene;
  // A tilting 2D scanner: azimuth over 270 deg, tilt over [-55, 45] deg, about square steps.
  const double az_span = 1.5 * M_PI, tilt_lo = -55.0 * M_PI / 180, tilt_hi = 45.0 * M_PI / 180;
  const int n_tilt = std::max(
      2, static_cast<int>(std::round(std::sqrt(opt.points * (tilt_hi - tilt_lo) / az_span))));
  const int n_az = std::max(2, opt.points / n_tilt);
  for (int it = 0; it < n_tilt; ++it) {
    const double tilt = tilt_lo + (tilt_hi - tilt_lo) * (it + 0.5) / n_tilt;
    for (int ia = 0; ia < n_az; ++ia) {
      const double az = -0.5 * az_span + az_span * (ia + 0.5) / n_az;
      const Eigen::Vector3d d(std::cos(tilt) * std::cos(az), std::cos(tilt) * std::sin(az),
                              std::sin(tilt));
      // Exit through the room's faces (the sensor is inside it).
      double t = std::numeric_limits<double>::infinity();
      int face = -1;
      for (int a = 0; a < 3; ++a) {
        if (d(a) > 1e-12 && (opt.room.hi(a) - opt.sensor(a)) / d(a) < t) {
          t = (opt.room.hi(a) - opt.sensor(a)) / d(a);
          face = 2 * a + 1;
        }
        if (d(a) < -1e-12 && (opt.room.lo(a) - opt.sensor(a)) / d(a) < t) {
          t = (opt.room.lo(a) - opt.sensor(a)) / d(a);
          face = 2 * a;
        }
      }
      int label = face == 4 ? kFloor : kRoom;
      for (std::size_t k = 0; k < opt.objects.size(); ++k) {
        const double tk = rayEnter(opt.sensor, d, opt.objects[k]);
        if (tk < t) {
          t = tk;
          label = kObject + static_cast<int>(k);
        }
      }
      const Eigen::Vector3d hit = opt.sensor + t * d;
      const Eigen::Vector3d p = opt.sensor + (t + opt.range_sigma_m * noise(rng)) * d;
      scene.cloud.push_back(
          PointT(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
      scene.label.push_back(label);
      scene.surface_z.push_back(hit.z());
    }
  }
  const int surface = static_cast<int>(scene.cloud.size());
  const int outliers = static_cast<int>(std::round(opt.outlier_fraction * surface));
  const Eigen::Vector3d ext = opt.room.hi - opt.room.lo;
  for (int k = 0; k < outliers;) {
    const Eigen::Vector3d p =
        opt.room.lo + Eigen::Vector3d(uni(rng), uni(rng), uni(rng)).cwiseProduct(ext);
    double clearance = std::min((p - opt.room.lo).minCoeff(), (opt.room.hi - p).minCoeff());
    for (const auto& b : opt.objects) {
      clearance = std::min(clearance, (b.lo - p).cwiseMax(p - b.hi).cwiseMax(0.0).norm());
    }
    if (clearance < opt.outlier_clearance_m) continue;
    ++k;
    scene.cloud.push_back(
        PointT(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
    scene.label.push_back(kOutlier);
    scene.surface_z.push_back(std::numeric_limits<double>::quiet_NaN());
  }
  const int nans = static_cast<int>(std::round(opt.nan_fraction * surface));
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int k = 0; k < nans; ++k) {
    scene.cloud.push_back(PointT(nan, nan, nan));
    scene.label.push_back(kNan);
    scene.surface_z.push_back(std::numeric_limits<double>::quiet_NaN());
  }
  // Shuffle so that outliers and NaNs are spread through the input order.
  std::vector<int> perm(scene.cloud.size());
  for (std::size_t i = 0; i < perm.size(); ++i) perm[i] = static_cast<int>(i);
  std::shuffle(perm.begin(), perm.end(), rng);
  Scene out;
  for (int i : perm) {
    out.cloud.push_back(scene.cloud[i]);
    out.label.push_back(scene.label[i]);
    out.surface_z.push_back(scene.surface_z[i]);
  }
  out.cloud.width = static_cast<std::uint32_t>(out.cloud.size());
  out.cloud.height = 1;
  out.cloud.is_dense = nans == 0;
  out.cloud.sensor_origin_ << opt.sensor.cast<float>(), 0.f;
  return out;
}

}  // namespace synthetic
}  // namespace novelty_detection
