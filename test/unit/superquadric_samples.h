// Seeded synthetic superquadric data with exact ground truth, shared by the superquadric
// tests and benchmarks: random poses, noisy surface samples, one-sided (sensor) views.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <random>

#include "novelty_detection/shape/superquadric.h"

namespace novelty_detection {
namespace samples {

inline Superquadric makeSq(const Eigen::Vector3d& a, double e1, double e2,
                           const Eigen::Vector3d& euler = Eigen::Vector3d::Zero(),
                           const Eigen::Vector3d& position = Eigen::Vector3d::Zero()) {
  Superquadric sq;
  sq.a = a;
  sq.e1 = e1;
  sq.e2 = e2;
  sq.euler = euler;
  sq.position = position;
  return sq;
}

/// A random orientation (uniform quaternion) and a position within +-2 m.
inline void randomPose(Superquadric& sq, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  Eigen::Quaterniond q(n(rng), n(rng), n(rng), n(rng));
  q.normalize();
  sq.euler = eulerZyzFromRotation(q.toRotationMatrix());
  sq.position = Eigen::Vector3d(u(rng), u(rng), u(rng));
}

/// Surface samples with isotropic Gaussian noise sigma_m. With a sensor, only points whose
/// outward normal faces the sensor are kept (a one-sided laser view).
inline Points3d noisySamples(const Superquadric& sq, int count, double sigma_m, unsigned seed,
                             const Eigen::Vector3d* sensor = nullptr) {
  const Points3d clean = sampleSurfaceRandom(sq, count, seed);
  std::mt19937 rng(seed + 7919u);
  std::normal_distribution<double> noise(0.0, 1.0);
  Points3d out;
  for (const auto& p : clean) {
    if (sensor && surfaceNormal(sq, p).dot(*sensor - p) <= 0.0) continue;
    Eigen::Vector3d q = p;
    if (sigma_m > 0.0) q += Eigen::Vector3d(noise(rng), noise(rng), noise(rng)) * sigma_m;
    out.push_back(q);
  }
  return out;
}

/// Mean over the sorted axes of |fitted - true| [m]: the size error whatever the axes' order.
inline double semiAxisError(const Superquadric& fit, const Superquadric& truth) {
  Eigen::Vector3d a = fit.a, b = truth.a;
  std::sort(a.data(), a.data() + 3);
  std::sort(b.data(), b.data() + 3);
  return (a - b).cwiseAbs().mean();
}

/// Mean radial distance of the clean (noise-free) ground-truth surface samples to a fitted
/// model: the recovered-surface accuracy independent of the noise.
inline double surfaceError(const Superquadric& truth, const Superquadric& fitted,
                           int count = 2000) {
  return meanRadialDistance(fitted, sampleSurfaceRandom(truth, count, 12345u));
}

}  // namespace samples
}  // namespace novelty_detection
