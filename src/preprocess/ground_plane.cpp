// Ground plane removal (paper Sec. IV-A, "a simple method using RANSAC to fit a ground
// plane"), made robust to the sensor's noise level and to what stands on the floor.
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>

#include "common/parallel.h"
#include "novelty_detection/preprocess/input_check.h"
#include "novelty_detection/preprocess/preprocess.h"

namespace novelty_detection {
namespace {

constexpr unsigned kSeed = 20020101u;  // fixed: the result is deterministic

struct Hypothesis {
  Eigen::Vector3d normal;
  double d;
  int support;
  double inlier_z;  ///< mean height of its inliers
};

double medianOf(std::vector<double>& v) {
  const std::size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + mid, v.end());
  return v[mid];
}

/// Location and scale of the floor's residuals `r` (all within [-w, w] of the current
/// plane): a Gaussian for the floor's noise plus a uniform density over the window for what
/// crosses it (walls, legs, boxes standing on the floor). A median/MAD of the window is pulled
/// by that clutter, and re-centring the window on a wider sigma feeds on itself (seen: 6 cm
/// for a 1.2 cm floor in a cluttered corridor); the mixture's Gaussian is not. EM from the
/// median and the given sigma, a fixed number of rounds.
void floorNoise(const std::vector<double>& r, double w, double* mu, double* sigma) {
  const double uniform = 1.0 / (2.0 * w);
  double pi = 0.5, m = *mu, s = *sigma;
  std::vector<double> resps(r.size());  // each residual's responsibility, for both sums
  for (int it = 0; it < 30; ++it) {
    double sw = 0.0, swr = 0.0, swrr = 0.0;
    for (std::size_t i = 0; i < r.size(); ++i) {
      const double x = r[i];
      const double z = (x - m) / s;
      const double g = pi * std::exp(-0.5 * z * z) / (s * std::sqrt(2.0 * M_PI));
      const double resp = g / (g + (1.0 - pi) * uniform);
      resps[i] = resp;
      sw += resp;
      swr += resp * x;
    }
    if (!(sw > 3.0)) break;
    const double new_m = swr / sw;
    for (std::size_t i = 0; i < r.size(); ++i) {
      const double x = r[i];
      swrr += resps[i] * (x - new_m) * (x - new_m);
    }
    const double new_s = std::max(std::sqrt(swrr / sw), 1e-5);
    const bool done = std::abs(new_s - s) <= 1e-3 * s && std::abs(new_m - m) <= 1e-6;
    pi = std::clamp(sw / static_cast<double>(r.size()), 0.01, 0.999);
    m = new_m;
    s = new_s;
    if (done) break;
  }
  *mu = m;
  *sigma = s;
}

/// Plane n.p + d = 0 with unit normal pointing up (n.z >= 0).
Eigen::Vector4d planeUp(const Eigen::Vector3d& normal, double d) {
  return normal.z() < 0 ? Eigen::Vector4d(-normal.x(), -normal.y(), -normal.z(), -d)
                        : Eigen::Vector4d(normal.x(), normal.y(), normal.z(), d);
}

/// A plane refined to a fixed point of (plane, sigma) on the sample (thousands of floor
/// points fix it to a fraction of a millimetre): the plane from the points in a 3-sigma band,
/// offset and sigma from the floor-plus-clutter mixture of floorNoise().
struct Refined {
  Eigen::Vector3d normal;
  double d;
  double sigma;
  int support;  ///< sample points within t of it (one band for all, so tilts compare fairly)
};

Refined refine(const std::vector<Eigen::Vector3d>& sample, const Eigen::Vector3d& centre,
               const Hypothesis& start, double t, double cos_max) {
  Eigen::Vector3d normal = start.normal;
  double d = start.d;
  double sigma = t;
  std::vector<double> res;
  res.reserve(sample.size());
  for (int it = 0; it < 20; ++it) {
    const double band = std::max(t, 3.0 * sigma);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    double xx = 0.0, xy = 0.0, xz = 0.0, yy = 0.0, yz = 0.0, zz = 0.0;  // sum q q^T
    int count = 0;
    for (const auto& p : sample) {
      if (std::abs(normal.dot(p) + d) > band) continue;
      const Eigen::Vector3d q = p - centre;
      sum += q;
      xx += q.x() * q.x(), xy += q.x() * q.y(), xz += q.x() * q.z();
      yy += q.y() * q.y(), yz += q.y() * q.z(), zz += q.z() * q.z();
      ++count;
    }
    if (count < 3) break;
    const Eigen::Vector3d mean = sum / count;
    Eigen::Matrix3d sum2;
    sum2 << xx, xy, xz, xy, yy, yz, xz, yz, zz;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
    es.computeDirect(sum2 / count - mean * mean.transpose());
    Eigen::Vector3d new_normal = es.eigenvectors().col(0);
    if (new_normal.z() < 0) new_normal = -new_normal;
    if (!new_normal.allFinite() || new_normal.z() < cos_max) break;  // keep the last plane
    // Offset and scale from the residuals around the new normal, in a window wide enough
    // for the clutter to look uniform (ten inlier distances).
    res.clear();
    const double d0 = -new_normal.dot(centre + mean);
    const double window = 10.0 * t;
    for (const auto& p : sample) {
      const double r = new_normal.dot(p) + d0;
      if (std::abs(r) <= window) res.push_back(r);
    }
    if (res.size() < 3) break;
    double med = 0.0, new_sigma = sigma;
    {
      std::vector<double> tmp = res;
      med = medianOf(tmp);
    }
    floorNoise(res, window, &med, &new_sigma);
    const double new_d = d0 - med;
    const bool converged = std::abs(new_sigma - sigma) <= 0.005 * sigma &&
                           std::abs(new_d - d) <= 1e-4 && new_normal.dot(normal) > 1 - 1e-9;
    normal = new_normal;
    d = new_d;
    sigma = new_sigma;
    if (converged) break;
  }
  int support = 0;
  for (const auto& p : sample) support += std::abs(normal.dot(p) + d) <= t;
  return {normal, d, sigma, support};
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
                            const PreprocessParams& params, const Eigen::Vector3f* sensor_origin,
                            int threads) {
  params.validate();
  GroundPlane ground;
  std::vector<Eigen::Vector3d> pts;
  pts.reserve(indices.size());
  for (int i : indices) {
    requireIndexInCloud(cloud, i, "findGroundPlane");
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
  const bool has_origin = sensor_origin && sensor_origin->allFinite();
  const Eigen::Vector3d origin = has_origin ? sensor_origin->cast<double>() : Eigen::Vector3d();
  // The lowest fifth of the sample: a quarter of the triples come from there.
  std::vector<Eigen::Vector3d> low;
  {
    std::vector<double> z;
    z.reserve(sample.size());
    for (const auto& p : sample) z.push_back(p.z());
    const std::size_t q = z.size() / 5;
    std::nth_element(z.begin(), z.begin() + q, z.end());
    for (const auto& p : sample)
      if (p.z() <= z[q]) low.push_back(p);
  }
  std::uniform_int_distribution<int> pick_low(0, std::max(0, static_cast<int>(low.size()) - 1));
  // A near-horizontal plane through three points (not below the sensor), and its score on
  // the sample. The triples are drawn in turn and the planes scored afterwards, on up to
  // `threads` threads (the scores do not depend on the draws).
  auto plane = [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                   const Eigen::Vector3d& c) -> std::optional<Hypothesis> {
    Eigen::Vector3d normal = (b - a).cross(c - a);
    const double len = normal.norm();
    if (!(len > 1e-12)) return std::nullopt;  // collinear or repeated points
    normal /= len;
    if (std::abs(normal.z()) < cos_max) return std::nullopt;
    if (normal.z() < 0) normal = -normal;
    const double d = -normal.dot(a);
    if (has_origin && normal.dot(origin) + d <= t) return std::nullopt;  // not below the sensor
    return Hypothesis{normal, d, 0, 0.0};
  };
  // The sample by coordinate, for the scores: the band test lists a plane's inliers without
  // a branch, and only their heights are then summed, in the sample's order (the same sum as
  // adding 0 for every other point, a shorter chain of additions).
  std::vector<double> sx(static_cast<std::size_t>(m)), sy(sx), sz(sx);
  for (int j = 0; j < m; ++j) sx[j] = sample[j].x(), sy[j] = sample[j].y(), sz[j] = sample[j].z();
  const auto score = [&](std::vector<Hypothesis>* planes, std::size_t from) {
    detail::parallelFor(static_cast<int>(planes->size() - from), threads, [&](int k) {
      Hypothesis& h = (*planes)[from + static_cast<std::size_t>(k)];
      const double nx = h.normal.x(), ny = h.normal.y(), nz = h.normal.z(), hd = h.d;
      // The inlier list of the thread's hypotheses, allocated once per thread.
      thread_local std::vector<int> inliers;
      inliers.resize(static_cast<std::size_t>(m));
      int support = 0;
      for (int j = 0; j < m; ++j) {
        inliers[support] = j;
        support += std::abs(nx * sx[j] + ny * sy[j] + nz * sz[j] + hd) <= t;
      }
      double z = 0.0;
      for (int j = 0; j < support; ++j) z += sz[inliers[j]];
      h.support = support;
      h.inlier_z = support > 0 ? z / support : 0.0;
    });
  };
  std::vector<Hypothesis> hyps;
  // Triples tilted beyond the angle cost only a cross product: draw until max_iterations
  // planes were found, or 20 times that many triples.
  for (int draws = 0; draws < 20 * params.ground_max_iterations &&
                      static_cast<int>(hyps.size()) < params.ground_max_iterations;
       ++draws) {
    const bool from_low = draws % 4 == 3 && low.size() >= 3;
    const std::vector<Eigen::Vector3d>& set = from_low ? low : sample;
    auto& dist = from_low ? pick_low : pick;
    const Eigen::Vector3d& a = set[dist(rng)];
    const Eigen::Vector3d& b = set[dist(rng)];
    const Eigen::Vector3d& c = set[dist(rng)];
    if (const auto h = plane(a, b, c)) hyps.push_back(*h);
  }
  score(&hyps, 0);
  if (hyps.empty()) return ground;

  // The lowest strongly supported surface: planes in order of support, a later one taking
  // over only when its inliers lie clearly (3 inlier distances) lower. Heights are those of
  // the inliers, not of the planes at some point: a plane tilted through the floor holds a
  // strip of floor points at the floor's height and so never passes for a lower surface,
  // while a floor below a large table top does.
  std::stable_sort(hyps.begin(), hyps.end(),
                   [](const Hypothesis& a, const Hypothesis& b) { return a.support > b.support; });
  const int best = hyps.front().support;
  if (best < 3) return ground;
  const Hypothesis* chosen = &hyps.front();
  for (const auto& h : hyps) {
    if (h.support < params.ground_lowest_support * best) break;
    if (h.inlier_z < chosen->inlier_z - 3.0 * t) chosen = &h;
  }
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const auto& p : sample) centre += p;
  centre /= m;

  // 2. Local optimisation at that height. A hypothesis tilted through the floor can settle
  // on a tilted fixed point (a strip of floor plus the feet of what stands on it), and when
  // the floor is a small part of the sweep RANSAC may hold no level floor plane at all. So
  // planes are also drawn from the points near the chosen one (mostly floor, whatever its
  // tilt), and the strongest candidates at that height are refined. The floor is the
  // refined plane with the most points per unit of noise: a tilted fit gathers clutter and
  // with it a larger sigma.
  const Hypothesis start = *chosen;
  std::vector<Eigen::Vector3d> local;
  for (const auto& p : sample)
    if (std::abs(start.normal.dot(p) + start.d) <= 3.0 * t) local.push_back(p);
  std::vector<Hypothesis> candidates{start};
  if (local.size() >= 3) {
    std::uniform_int_distribution<int> pick_local(0, static_cast<int>(local.size()) - 1);
    for (int draws = 0; draws < 20 * params.ground_max_iterations &&
                        static_cast<int>(candidates.size()) <= params.ground_max_iterations / 4;
         ++draws) {
      const Eigen::Vector3d& a = local[pick_local(rng)];
      const Eigen::Vector3d& b = local[pick_local(rng)];
      const Eigen::Vector3d& c = local[pick_local(rng)];
      if (const auto h = plane(a, b, c)) candidates.push_back(*h);
    }
    score(&candidates, 1);
  }
  for (const auto& h : hyps) {
    if (&h != chosen && std::abs(h.inlier_z - start.inlier_z) <= 3.0 * t) candidates.push_back(h);
  }
  std::stable_sort(candidates.begin() + 1, candidates.end(),
                   [](const Hypothesis& a, const Hypothesis& b) { return a.support > b.support; });
  candidates.resize(std::min<std::size_t>(candidates.size(), 8));
  // Refinement can drift (a fixed point tilted through the clutter near the robot); a refined
  // plane the sensor does not lie above is no floor either.
  std::vector<Refined> refinements(candidates.size());
  detail::parallelFor(static_cast<int>(candidates.size()), threads, [&](int k) {
    refinements[static_cast<std::size_t>(k)] =
        refine(sample, centre, candidates[static_cast<std::size_t>(k)], t, cos_max);
  });
  Refined refined;
  bool have_refined = false;
  for (const Refined& r : refinements) {
    if (has_origin && r.normal.dot(origin) + r.d <= t) continue;
    if (!have_refined || r.support / r.sigma > refined.support / refined.sigma) refined = r;
    have_refined = true;
  }
  if (!have_refined) return ground;  // found stays false: nothing is removed
  const Eigen::Vector3d normal = refined.normal;
  const double d = refined.d;
  const double sigma = refined.sigma;

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
