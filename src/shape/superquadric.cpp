#include "novelty_detection/shape/superquadric.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include "shape/superquadric_kernel.h"

namespace novelty_detection {
namespace {

constexpr double kPi = 3.14159265358979323846;
// exp() of more than this overflows a double.
constexpr double kMaxLog = 690.0;

double logF(const Superquadric& sq, const Eigen::Vector3d& q) {
  return logInsideOutsideCanonical(q.x(), q.y(), q.z(), sq.a[0], sq.a[1], sq.a[2], sq.e1, sq.e2);
}

/// Gradient of log F in the canonical frame (see logInsideOutsideCanonical()); `log_f`
/// (optional) receives log F itself, computed from the same logs (bit-identical to logF()).
Eigen::Vector3d gradLogF(const Superquadric& sq, const Eigen::Vector3d& q,
                         double* log_f = nullptr) {
  const double e1 = sq.e1, e2 = sq.e2;
  const double lx = std::log(q.x() * q.x() / (sq.a[0] * sq.a[0]) + kSqTinySquared) / e2;
  const double ly = std::log(q.y() * q.y() / (sq.a[1] * sq.a[1]) + kSqTinySquared) / e2;
  const double lz = std::log(q.z() * q.z() / (sq.a[2] * sq.a[2]) + kSqTinySquared) / e1;
  const double lxy = logSumExp(lx, ly);
  const double la = e2 / e1 * lxy;
  const double l = logSumExp(la, lz);
  if (log_f) *log_f = l;
  const double wa = std::exp(la - l), wb = std::exp(lz - l);
  const double wx = std::exp(lx - lxy), wy = std::exp(ly - lxy);
  return Eigen::Vector3d(
      wa * wx * 2.0 / e1 * q.x() / (q.x() * q.x() + kSqTinySquared * sq.a[0] * sq.a[0]),
      wa * wy * 2.0 / e1 * q.y() / (q.y() * q.y() + kSqTinySquared * sq.a[1] * sq.a[1]),
      wb * 2.0 / e1 * q.z() / (q.z() * q.z() + kSqTinySquared * sq.a[2] * sq.a[2]));
}

double logBeta(double x, double y) { return std::lgamma(x) + std::lgamma(y) - std::lgamma(x + y); }

}  // namespace

Eigen::Vector3d toCanonical(const Superquadric& sq, const Eigen::Vector3d& p_world) {
  return sq.rotation().transpose() * (p_world - sq.position);
}

Eigen::Vector3d toWorld(const Superquadric& sq, const Eigen::Vector3d& p_sq) {
  return sq.rotation() * p_sq + sq.position;
}

double logInsideOutside(const Superquadric& sq, const Eigen::Vector3d& p_world) {
  return logF(sq, toCanonical(sq, p_world));
}

double insideOutside(const Superquadric& sq, const Eigen::Vector3d& p_world) {
  return std::exp(std::min(logInsideOutside(sq, p_world), kMaxLog));
}

double fitResidual(const Superquadric& sq, const Eigen::Vector3d& p_world) {
  const Eigen::Vector3d q = toCanonical(sq, p_world);
  return fitResidualCanonical(q.x(), q.y(), q.z(), sq.a[0], sq.a[1], sq.a[2], sq.e1, sq.e2);
}

double meanSquaredResidual(const Superquadric& sq, const Points3d& points) {
  if (points.empty()) return 0.0;
  const Eigen::Matrix3d rt = sq.rotation().transpose();
  double sum = 0.0;
  for (const auto& p : points) {
    const Eigen::Vector3d q = rt * (p - sq.position);
    const double r =
        fitResidualCanonical(q.x(), q.y(), q.z(), sq.a[0], sq.a[1], sq.a[2], sq.e1, sq.e2);
    sum += r * r;
  }
  return sum / static_cast<double>(points.size());
}

namespace {
double radialDistanceCanonical(const Superquadric& sq, const Eigen::Vector3d& q) {
  const double norm = q.norm();
  if (norm < 1e-12 * sq.a.minCoeff()) return sq.a.minCoeff();
  // Surface radius along this ray: r_s = |q| F^(-e1/2) (F is homogeneous of degree 2/e1).
  const double log_rs = std::log(norm) - 0.5 * sq.e1 * logF(sq, q);
  return std::abs(norm - std::exp(std::min(log_rs, kMaxLog)));
}
}  // namespace

double radialDistance(const Superquadric& sq, const Eigen::Vector3d& p_world) {
  return radialDistanceCanonical(sq, toCanonical(sq, p_world));
}

// The vectorised distances read a Points3d as consecutive xyz triples.
static_assert(sizeof(Eigen::Vector3d) == 3 * sizeof(double), "Vector3d is three doubles");

namespace {
/// Mean of the vectorised distances (radial or surface) over points, summed in order.
double meanDistance(const Superquadric& sq, const Points3d& points, bool surface) {
  if (points.empty()) return 0.0;
  const double shape[5] = {sq.a[0], sq.a[1], sq.a[2], sq.e1, sq.e2};
  const Eigen::Matrix3d r = sq.rotation();
  double chunk[detail::kKernelChunk];
  double sum = 0.0;
  const auto n = static_cast<Eigen::Index>(points.size());
  for (Eigen::Index begin = 0; begin < n; begin += detail::kKernelChunk) {
    const Eigen::Index m = std::min(detail::kKernelChunk, n - begin);
    detail::superquadricDistances(shape, r.data(), sq.position.data(),
                                  points[static_cast<std::size_t>(begin)].data(), nullptr, m,
                                  surface, chunk);
    for (Eigen::Index i = 0; i < m; ++i) sum += chunk[i];
  }
  return sum / static_cast<double>(points.size());
}
}  // namespace

double meanRadialDistance(const Superquadric& sq, const Points3d& points) {
  return meanDistance(sq, points, false);
}

namespace {
/// surfaceDistance() in the canonical frame; `log_f` and `grad` (optional) receive log F and
/// its gradient there (one set of logs for all three).
double surfaceDistanceCanonical(const Superquadric& sq, const Eigen::Vector3d& q,
                                double* log_f = nullptr, Eigen::Vector3d* grad = nullptr) {
  double l = 0.0;
  const Eigen::Vector3d gv = gradLogF(sq, q, &l);
  if (log_f) *log_f = l;
  if (grad) *grad = gv;
  const double g = gv.norm();
  const double d =
      std::abs(1.0 - std::exp(std::min(-0.5 * sq.e1 * l, kMaxLog))) / (0.5 * sq.e1 * g);
  return std::isfinite(d) ? d : radialDistanceCanonical(sq, q);
}

/// Outward unit normal from the canonical-frame gradient of log F at q.
Eigen::Vector3d normalFromGradient(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& q,
                                   Eigen::Vector3d g) {
  const double n = g.norm();
  if (!(n > 0.0) || !std::isfinite(n)) {
    // At the centre there is no gradient: fall back to the radial direction or +z.
    g = q.norm() > 0.0 ? q : Eigen::Vector3d::UnitZ();
  }
  return (rotation * g).normalized();
}
}  // namespace

double surfaceDistance(const Superquadric& sq, const Eigen::Vector3d& p_world) {
  return surfaceDistanceCanonical(sq, toCanonical(sq, p_world));
}

double signedSurfaceDistance(const Superquadric& sq, const Eigen::Vector3d& p_world) {
  const Eigen::Vector3d q = toCanonical(sq, p_world);
  double l = 0.0;
  const double d = surfaceDistanceCanonical(sq, q, &l);
  return l < 0.0 ? -d : d;
}

SurfaceQuery::SurfaceQuery(const Superquadric& sq) : rotation_(sq.rotation()) {
  // The geometry only (not the indices).
  sq_.a = sq.a;
  sq_.e1 = sq.e1;
  sq_.e2 = sq.e2;
  sq_.euler = sq.euler;
  sq_.position = sq.position;
}

double SurfaceQuery::distance(const Eigen::Vector3d& p_world) const {
  return surfaceDistanceCanonical(sq_, rotation_.transpose() * (p_world - sq_.position));
}

void SurfaceQuery::distances(const Points3d& points, const Indices& indices, double* out) const {
  const double shape[5] = {sq_.a[0], sq_.a[1], sq_.a[2], sq_.e1, sq_.e2};
  if (indices.empty()) return;
  detail::superquadricDistances(shape, rotation_.data(), sq_.position.data(), points.front().data(),
                                indices.data(), static_cast<Eigen::Index>(indices.size()), true,
                                out);
}

double SurfaceQuery::signedDistance(const Eigen::Vector3d& p_world, Eigen::Vector3d* normal) const {
  const Eigen::Vector3d q = rotation_.transpose() * (p_world - sq_.position);
  double l = 0.0;
  Eigen::Vector3d g;
  const double d = surfaceDistanceCanonical(sq_, q, &l, &g);
  if (normal) *normal = normalFromGradient(rotation_, q, g);
  return l < 0.0 ? -d : d;
}

double meanSurfaceDistance(const Superquadric& sq, const Points3d& points) {
  return meanDistance(sq, points, true);
}

Eigen::Vector3d surfaceNormal(const Superquadric& sq, const Eigen::Vector3d& p_world) {
  const Eigen::Vector3d q = toCanonical(sq, p_world);
  return normalFromGradient(sq.rotation(), q, gradLogF(sq, q));
}

Eigen::Vector3d surfacePointAlong(const Superquadric& sq, const Eigen::Vector3d& dir_sq) {
  const double norm = dir_sq.norm();
  if (!(norm > 0.0) || !std::isfinite(norm)) {
    throw std::invalid_argument("surfacePointAlong: direction must be finite and non-zero");
  }
  const Eigen::Vector3d d = dir_sq / norm;
  const double log_rs = -0.5 * sq.e1 * logF(sq, d);  // |d| = 1
  return toWorld(sq, d * std::exp(log_rs));
}

double volume(const Superquadric& sq) {
  const double e1 = sq.e1, e2 = sq.e2;
  return 2.0 * sq.a[0] * sq.a[1] * sq.a[2] * e1 * e2 *
         std::exp(logBeta(0.5 * e1 + 1.0, e1) + logBeta(0.5 * e2, 0.5 * e2));
}

TriangleMesh triangleMesh(const Superquadric& sq, int resolution) {
  if (resolution < 1) throw std::invalid_argument("triangleMesh: resolution must be >= 1");
  const int n = resolution;
  const int side = n + 1;
  // Lattice points (i, j, k) in {0..n}^3 on the cube's boundary are the vertices; a lattice
  // index -> vertex index table makes the faces share their edges (closed mesh).
  std::vector<int> index(static_cast<std::size_t>(side) * side * side, -1);
  auto lattice = [side](int i, int j, int k) {
    return (static_cast<std::size_t>(i) * side + j) * side + k;
  };
  // Equi-angular coordinate on [-1, 1]: tan of evenly spaced angles.
  std::vector<double> coord(side);
  for (int i = 0; i <= n; ++i) coord[i] = std::tan(kPi / 4.0 * (2.0 * i / n - 1.0));
  coord[0] = -1.0;
  coord[n] = 1.0;

  TriangleMesh mesh;
  mesh.vertices.reserve(6 * n * n + 2);
  mesh.triangles.reserve(12 * n * n);
  auto vertex = [&](int i, int j, int k) {
    int& id = index[lattice(i, j, k)];
    if (id < 0) {
      // Cube point scaled by the sizes, then projected radially onto the surface: for a
      // box-like shape it already lies on it, for round shapes the spacing stays even.
      const Eigen::Vector3d dir(sq.a[0] * coord[i], sq.a[1] * coord[j], sq.a[2] * coord[k]);
      id = static_cast<int>(mesh.vertices.size());
      mesh.vertices.push_back(surfacePointAlong(sq, dir));
    }
    return id;
  };
  for (int axis = 0; axis < 3; ++axis) {
    const int b = (axis + 1) % 3, c = (axis + 2) % 3;  // e_b x e_c = e_axis
    for (int sign = -1; sign <= 1; sign += 2) {
      const int fixed = sign > 0 ? n : 0;
      auto at = [&](int s, int t) {
        int ijk[3];
        ijk[axis] = fixed;
        ijk[b] = s;
        ijk[c] = t;
        return vertex(ijk[0], ijk[1], ijk[2]);
      };
      for (int s = 0; s < n; ++s) {
        for (int t = 0; t < n; ++t) {
          const int v00 = at(s, t), v10 = at(s + 1, t), v11 = at(s + 1, t + 1), v01 = at(s, t + 1);
          // (s, t) -> (s+1, t) -> (s+1, t+1) is counter-clockwise seen from +e_axis.
          if (sign > 0) {
            mesh.triangles.emplace_back(v00, v10, v11);
            mesh.triangles.emplace_back(v00, v11, v01);
          } else {
            mesh.triangles.emplace_back(v00, v11, v10);
            mesh.triangles.emplace_back(v00, v01, v11);
          }
        }
      }
    }
  }
  return mesh;
}

Points3d sampleSurface(const Superquadric& sq, int count) {
  if (count < 1) throw std::invalid_argument("sampleSurface: count must be >= 1");
  const int resolution =
      std::max(1, static_cast<int>(std::lround(std::sqrt(std::max(0.0, (count - 2) / 6.0)))));
  return triangleMesh(sq, resolution).vertices;
}

Points3d sampleSurfaceRandom(const Superquadric& sq, int count, unsigned seed) {
  if (count < 0) throw std::invalid_argument("sampleSurfaceRandom: count must be >= 0");
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> face(0, 5);
  std::uniform_real_distribution<double> angle(-kPi / 4.0, kPi / 4.0);
  Points3d out;
  out.reserve(static_cast<std::size_t>(count));
  for (int k = 0; k < count; ++k) {
    const int f = face(rng);
    const int axis = f / 2;
    Eigen::Vector3d c;
    c[axis] = (f % 2) ? 1.0 : -1.0;
    c[(axis + 1) % 3] = std::tan(angle(rng));
    c[(axis + 2) % 3] = std::tan(angle(rng));
    out.push_back(surfacePointAlong(sq, sq.a.cwiseProduct(c)));
  }
  return out;
}

Eigen::Vector3d eulerZyzFromRotation(const Eigen::Matrix3d& r) {
  // R = Rz(phi) Ry(theta) Rz(psi): R(2,2) = cos(theta), R(0,2) = cos(phi) sin(theta),
  // R(1,2) = sin(phi) sin(theta), R(2,0) = -sin(theta) cos(psi), R(2,1) = sin(theta) sin(psi).
  const double s = std::hypot(r(0, 2), r(1, 2));
  const double theta = std::atan2(s, r(2, 2));
  double phi, psi;
  if (s > 1e-9) {
    phi = std::atan2(r(1, 2), r(0, 2));
    psi = std::atan2(r(2, 1), -r(2, 0));
  } else if (r(2, 2) > 0.0) {
    // theta ~ 0: R ~ Rz(phi + psi).
    psi = 0.0;
    phi = std::atan2(r(1, 0), r(0, 0));
  } else {
    // theta ~ pi: R ~ Rz(phi) Ry(pi) Rz(psi) = Rz(phi - psi) diag(-1, 1, -1).
    psi = 0.0;
    phi = std::atan2(-r(1, 0), -r(0, 0));
  }
  return Eigen::Vector3d(phi, theta, psi);
}

}  // namespace novelty_detection
