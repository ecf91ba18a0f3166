// Ground plane removal (paper Sec. IV-A, "a simple method using RANSAC to fit a ground
// plane"), made robust to the sensor's noise level and to what stands on the floor.
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>

#include "novelty_detection/preprocess.h"

namespace novelty_detection {
namespace {

constexpr double kMadToSigma = 1.4826;  // MAD of a normal distribution is 0.6745 sigma
constexpr unsigned kSeed = 20020101u;   // fixed: the result is deterministic

struct Hypothesis {
  Eigen::Vector3d normal;
  double d;
  int support;
};

double medianOf(std::vector<double>& v) {
  const std::size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + mid, v.end());
  return v[mid];
}

/// Plane n.p + d = 0 with unit normal pointing up (n.z >= 0).
Eigen::Vector4d planeUp(const Eigen::Vector3d& normal, double d) {
  return normal.z() < 0 ? Eigen::Vector4d(-normal.x(), -normal.y(), -normal.z(), -d)
                        : Eigen::Vector4d(normal.x(), normal.y(), normal.z(), d);
}

}  // namespace

GroundPlane findGroundPlane(const Cloud& cloud, const Indices& indices, double distance_m,
                            double max_angle_deg, int max_iterations) {
  PreprocessParams params;
  params.ground_distance_m = distance_m;
  params.ground_max_angle_deg = max_angle_deg;
  params.ground_max_iterations = max_iterations;
  return findGroundPlane(cloud, indices, params);
}

GroundPlane findGroundPlane(const Cloud& cloud, const Indices& indices,
                            const PreprocessParams& params) {
  params.validate();
  GroundPlane ground;
  std::vector<Eigen::Vector3d> pts;
  pts.reserve(indices.size());
  for (int i : indices) {
    if (i < 0 || i >= static_cast<int>(cloud.size())) {
      throw std::invalid_argument("findGroundPlane: index " + std::to_string(i) +
                                  " outside a cloud of " + std::to_string(cloud.size()) +
                                  " points");
    }
    const Eigen::Vector3d p = cloud[i].getVector3fMap().cast<double>();
    if (!p.allFinite()) {
      throw std::invalid_argument("findGroundPlane: point " + std::to_string(i) + " is not finite");
    }
    pts.push_back(p);
  }
  const int n = static_cast<int>(pts.size());
  if (n < 3) return ground;

  // 1. RANSAC on a random subset (its size bounds the cost, not the cloud's).
  std::mt19937 rng(kSeed);
  std::vector<Eigen::Vector3d> sample;
  if (n <= params.ground_sample_points) {
    sample = pts;
  } else {
    std::uniform_int_distribution<int> pick(0, n - 1);
    sample.reserve(params.ground_sample_points);
    for (int s = 0; s < params.ground_sample_points; ++s) sample.push_back(pts[pick(rng)]);
  }
  const int m = static_cast<int>(sample.size());
  const double cos_max = std::cos(params.ground_max_angle_deg * M_PI / 180.0);
  const double t = params.ground_distance_m;
  std::uniform_int_distribution<int> pick(0, m - 1);
  std::vector<Hypothesis> hyps;
  // Triples tilted beyond the angle cost only a cross product: draw until max_iterations
  // hypotheses were scored, or 20 times that many triples.
  for (int draws = 0; draws < 20 * params.ground_max_iterations &&
                      static_cast<int>(hyps.size()) < params.ground_max_iterations;
       ++draws) {
    const Eigen::Vector3d& a = sample[pick(rng)];
    const Eigen::Vector3d& b = sample[pick(rng)];
    const Eigen::Vector3d& c = sample[pick(rng)];
    Eigen::Vector3d normal = (b - a).cross(c - a);
    const double len = normal.norm();
    if (!(len > 1e-12)) continue;  // collinear or repeated points
    normal /= len;
    if (std::abs(normal.z()) < cos_max) continue;
    if (normal.z() < 0) normal = -normal;
    const double d = -normal.dot(a);
    int support = 0;
    for (const auto& p : sample) support += std::abs(normal.dot(p) + d) <= t;
    hyps.push_back({normal, d, support});
  }
  if (hyps.empty()) return ground;

  int best = 0;
  for (const auto& h : hyps) best = std::max(best, h.support);
  // The lowest strongly supported plane, its height taken above the sample's centre.
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const auto& p : sample) centre += p;
  centre /= m;
  const Hypothesis* chosen = nullptr;
  double lowest = 0.0;
  for (const auto& h : hyps) {
    if (h.support < params.ground_lowest_support * best || h.support < 3) continue;
    const double z = -(h.d + h.normal.x() * centre.x() + h.normal.y() * centre.y()) / h.normal.z();
    if (!chosen || z < lowest) {
      chosen = &h;
      lowest = z;
    }
  }
  if (!chosen) return ground;

  // 2. Refinement to a fixed point of (plane, sigma), on the same subset (thousands of floor
  // points fix the plane to a fraction of a millimetre). A 3-sigma band keeps the MAD
  // within 1 % of sigma, and sigma grows towards its value from any too small start.
  Eigen::Vector3d normal = chosen->normal;
  double d = chosen->d;
  double sigma = t;
  std::vector<double> res;
  res.reserve(m);
  for (int it = 0; it < 20; ++it) {
    const double band = std::max(t, 3.0 * sigma);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Matrix3d sum2 = Eigen::Matrix3d::Zero();
    int count = 0;
    for (const auto& p : sample) {
      if (std::abs(normal.dot(p) + d) > band) continue;
      const Eigen::Vector3d q = p - centre;
      sum += q;
      sum2.noalias() += q * q.transpose();
      ++count;
    }
    if (count < 3) break;
    const Eigen::Vector3d mean = sum / count;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
    es.computeDirect(sum2 / count - mean * mean.transpose());
    Eigen::Vector3d new_normal = es.eigenvectors().col(0);
    if (new_normal.z() < 0) new_normal = -new_normal;
    if (!new_normal.allFinite() || new_normal.z() < cos_max) break;  // keep the last plane
    // Offset and scale from the residuals in the band, around the new normal.
    res.clear();
    const double d0 = -new_normal.dot(centre + mean);
    for (const auto& p : sample) {
      const double r = new_normal.dot(p) + d0;
      if (std::abs(r) <= band) res.push_back(r);
    }
    if (res.size() < 3) break;
    const double med = medianOf(res);
    for (auto& r : res) r = std::abs(r - med);
    const double new_sigma = kMadToSigma * medianOf(res);
    const double new_d = d0 - med;
    const bool converged = std::abs(new_sigma - sigma) <= 0.005 * sigma &&
                           std::abs(new_d - d) <= 1e-4 && new_normal.dot(normal) > 1 - 1e-9;
    normal = new_normal;
    d = new_d;
    sigma = new_sigma;
    if (converged) break;
  }

  // 3. Inliers over all given points.
  ground.noise_sigma_m = sigma;
  ground.threshold_m = std::max(t, params.ground_noise_k * sigma);
  for (int k = 0; k < n; ++k) {
    if (std::abs(normal.dot(pts[k]) + d) <= ground.threshold_m) {
      ground.inliers.push_back(indices[k]);
    }
  }
  ground.coefficients = planeUp(normal, d);
  if (static_cast<double>(ground.inliers.size()) < params.ground_min_fraction * n ||
      ground.inliers.size() < 3) {
    ground.inliers.clear();
    return ground;  // found stays false: nothing is removed
  }
  ground.found = true;
  return ground;
}

}  // namespace novelty_detection
