// Superquadric (superellipsoid) geometry, paper Sec. V-A: the inside-outside function F
// (eq. 2), the fitting residual (eq. 3), radial Euclidean distance, volume, surface samples
// and a closed triangle mesh. ROS-free, header-light (Eigen only).
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <vector>

#include "novelty_detection/types.h"

namespace novelty_detection {

/// Squared normalised coordinates below this are clamped, so that log() and its derivative
/// stay finite for points on the axes or at the centre (guarded powers).
constexpr double kSqTinySquared = 1e-24;

/// log(exp(a) + exp(b)) without overflow; works for doubles and ceres::Jet.
template <class T>
T logSumExp(const T& a, const T& b) {
  using std::exp;
  using std::log;
  if (a > b) return a + log(T(1.0) + exp(b - a));
  return b + log(T(1.0) + exp(a - b));
}

/// log F of eq. 2 for a point (x, y, z) in the superquadric's canonical frame:
///   F = ((x/a1)^(2/e2) + (y/a2)^(2/e2))^(e2/e1) + (z/a3)^(2/e1).
/// Computed in log space from squared coordinates: no pow() of a negative or zero base, no
/// overflow for far points, finite derivatives on the axes. Templated for ceres::Jet.
template <class T>
T logInsideOutsideCanonical(const T& x, const T& y, const T& z, const T& a1, const T& a2,
                            const T& a3, const T& e1, const T& e2) {
  using std::log;
  const T tiny(kSqTinySquared);
  const T lx = log(x * x / (a1 * a1) + tiny) / e2;  // log (x/a1)^(2/e2)
  const T ly = log(y * y / (a2 * a2) + tiny) / e2;
  const T lz = log(z * z / (a3 * a3) + tiny) / e1;  // log (z/a3)^(2/e1)
  return logSumExp(T(e2 / e1) * logSumExp(lx, ly), lz);
}

/// Eq. 3's residual for one point in the canonical frame: sqrt(a1 a2 a3) (F^e1 - 1).
/// F^e1 = exp(e1 log F) grows only like (|p| / a)^2 for far points.
template <class T>
T fitResidualCanonical(const T& x, const T& y, const T& z, const T& a1, const T& a2, const T& a3,
                       const T& e1, const T& e2) {
  using std::exp;
  using std::sqrt;
  const T log_f = logInsideOutsideCanonical(x, y, z, a1, a2, a3, e1, e2);
  return sqrt(a1 * a2 * a3) * (exp(e1 * log_f) - T(1.0));
}

/// p_sq = R^T (p_world - position).
Eigen::Vector3d toCanonical(const Superquadric& sq, const Eigen::Vector3d& p_world);
/// Inverse of toCanonical().
Eigen::Vector3d toWorld(const Superquadric& sq, const Eigen::Vector3d& p_sq);

/// log F (eq. 2) at a world point: < 0 inside, 0 on the surface, > 0 outside.
double logInsideOutside(const Superquadric& sq, const Eigen::Vector3d& p_world);
/// F (eq. 2) at a world point: < 1 inside, 1 on the surface, > 1 outside. Saturates at
/// 1e300 instead of overflowing for very far points.
double insideOutside(const Superquadric& sq, const Eigen::Vector3d& p_world);
/// Eq. 3's residual sqrt(a1 a2 a3) (F^e1 - 1) at a world point.
double fitResidual(const Superquadric& sq, const Eigen::Vector3d& p_world);
/// Mean of eq. 3's squared residuals (the `residual` field's definition); 0 when empty.
double meanSquaredResidual(const Superquadric& sq, const Points3d& points);

/// Radial Euclidean distance of a point to the surface: along the ray from the centre
/// through the point, | |p| - r_s | = |p| |1 - F^(-e1/2)| in the canonical frame. At the
/// centre itself it is the smallest half size.
double radialDistance(const Superquadric& sq, const Eigen::Vector3d& p_world);
/// Mean radial distance over points [m] (the fit quality measure used throughout); 0 when
/// empty. Vectorised: equal to the mean of radialDistance() up to rounding.
double meanRadialDistance(const Superquadric& sq, const Points3d& points);

/// First-order Euclidean distance of a point to the surface, |f| / |grad f| with
/// f = F^(e1/2) - 1 (homogeneous of degree one, so exact for spheres and unbiased for a
/// point displaced along the normal). Unlike the radial distance it does not inflate the
/// noise on the long faces of elongated shapes, where rays from the centre meet the surface
/// obliquely. Falls back to the radial distance at the centre.
double surfaceDistance(const Superquadric& sq, const Eigen::Vector3d& p_world);
/// surfaceDistance() with a sign: negative inside (F < 1), positive outside.
double signedSurfaceDistance(const Superquadric& sq, const Eigen::Vector3d& p_world);
/// Mean of surfaceDistance() over points [m], vectorised (equal up to rounding); 0 when
/// empty.
double meanSurfaceDistance(const Superquadric& sq, const Points3d& points);

/// Outward unit normal of the level set of F through a world point (gradient direction).
Eigen::Vector3d surfaceNormal(const Superquadric& sq, const Eigen::Vector3d& p_world);

/// One superquadric prepared for many distance queries (its rotation computed once); the
/// results equal surfaceDistance(), signedSurfaceDistance() and surfaceNormal() exactly.
/// Keeps a copy of its geometry.
class SurfaceQuery {
 public:
  explicit SurfaceQuery(const Superquadric& sq);
  /// surfaceDistance().
  double distance(const Eigen::Vector3d& p_world) const;
  /// surfaceDistance() of points[indices[k]] into out[k], vectorised (equal to distance()
  /// up to rounding).
  void distances(const Points3d& points, const Indices& indices, double* out) const;
  /// signedSurfaceDistance(); `normal` (optional) receives surfaceNormal() at the same point.
  double signedDistance(const Eigen::Vector3d& p_world, Eigen::Vector3d* normal = nullptr) const;

 private:
  Superquadric sq_;
  Eigen::Matrix3d rotation_;
};

/// The surface point (world frame) on the ray from the centre along a canonical-frame
/// direction (need not be normalised; must be non-zero).
Eigen::Vector3d surfacePointAlong(const Superquadric& sq, const Eigen::Vector3d& dir_sq);

/// Volume [m^3], closed form (Jaklic et al. 2000):
///   V = 2 a1 a2 a3 e1 e2 B(e1/2 + 1, e1) B(e2/2, e2/2).
double volume(const Superquadric& sq);

/// A closed triangle mesh; triangles are wound counter-clockwise seen from outside.
struct TriangleMesh {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<Eigen::Vector3i> triangles;
};

/// Closed mesh of the surface. Built from a cube whose faces carry a resolution x resolution
/// equi-angular grid, projected radially onto the surface: no poles, spacing within about a
/// factor two everywhere, flat faces of box-like shapes stay evenly sampled.
/// Vertices: 6 r^2 + 2; triangles: 12 r^2. Throws std::invalid_argument if resolution < 1.
TriangleMesh triangleMesh(const Superquadric& sq, int resolution);

/// About `count` roughly evenly spaced surface points (the vertices of triangleMesh()).
Points3d sampleSurface(const Superquadric& sq, int count);

/// `count` random surface points (seeded, deterministic): uniform on the cube of
/// triangleMesh(), projected radially like its vertices.
Points3d sampleSurfaceRandom(const Superquadric& sq, int count, unsigned seed);

/// Z-Y-Z Euler angles (phi, theta, psi) of a rotation matrix, R = Rz(phi) Ry(theta) Rz(psi),
/// theta in [0, pi]. In gimbal lock (theta ~ 0 or pi) psi is set to 0 and phi absorbs the
/// whole rotation about z, so that the angles always reproduce R.
Eigen::Vector3d eulerZyzFromRotation(const Eigen::Matrix3d& rotation);

}  // namespace novelty_detection
