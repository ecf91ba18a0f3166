#include "novelty_detection/sim/primitives.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace novelty_detection {
namespace sim {
namespace {

std::optional<double> accept(double t, double t_max) {
  if (t > kRayEpsilon && t < t_max) return t;
  return std::nullopt;
}

// Root of a continuous f on [a, b] with f(a), f(b) of opposite signs: Illinois false position
// (superlinear, never leaves the bracket).
template <typename F>
double bracketedRoot(const F& f, double a, double fa, double b, double fb) {
  int side = 0;
  double c = a;
  for (int it = 0; it < 200; ++it) {
    c = (fa * b - fb * a) / (fa - fb);
    if (!(c > std::min(a, b) && c < std::max(a, b))) c = 0.5 * (a + b);
    const double fc = f(c);
    if (fc == 0.0 || std::abs(b - a) < 1e-10) break;
    if ((fc > 0) == (fb > 0)) {
      b = c;
      fb = fc;
      if (side == -1) fa *= 0.5;
      side = -1;
    } else {
      a = c;
      fa = fc;
      if (side == +1) fb *= 0.5;
      side = +1;
    }
  }
  return c;
}

Eigen::AlignedBox3d transformedBox(const Eigen::Vector3d& center, const Eigen::Matrix3d& R,
                                   const Eigen::Vector3d& half) {
  const Eigen::Vector3d ext = R.cwiseAbs() * half;
  return Eigen::AlignedBox3d(center - ext, center + ext);
}

}  // namespace

bool rayAabb(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
             const Eigen::Vector3d& box_min, const Eigen::Vector3d& box_max, double* t_enter,
             double* t_exit) {
  double t0 = -kInfinity, t1 = kInfinity;
  for (int i = 0; i < 3; ++i) {
    if (std::abs(dir[i]) < 1e-15) {
      if (origin[i] < box_min[i] || origin[i] > box_max[i]) return false;
      continue;
    }
    const double inv = 1.0 / dir[i];
    double ta = (box_min[i] - origin[i]) * inv;
    double tb = (box_max[i] - origin[i]) * inv;
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  *t_enter = t0;
  *t_exit = t1;
  return true;
}

// ------------------------------------------------------------------------------------------
Plane::Plane(const Eigen::Vector3d& point, const Eigen::Vector3d& normal, int object_id)
    : Primitive(object_id), point_(point), normal_(normal) {
  if (!(normal.norm() > 1e-12)) throw std::invalid_argument("Plane: normal has zero length");
  normal_.normalize();
}

std::optional<double> Plane::intersect(const Ray& ray, double t_max) const {
  const double denom = normal_.dot(ray.dir);
  if (std::abs(denom) < 1e-15) return std::nullopt;  // parallel
  return accept(normal_.dot(point_ - ray.origin) / denom, t_max);
}

Eigen::AlignedBox3d Plane::bounds() const {
  return Eigen::AlignedBox3d(Eigen::Vector3d::Constant(-kInfinity),
                             Eigen::Vector3d::Constant(kInfinity));
}

// ------------------------------------------------------------------------------------------
Quad::Quad(const Eigen::Vector3d& center, const Eigen::Vector3d& u, const Eigen::Vector3d& v,
           double half_u, double half_v, int object_id)
    : Primitive(object_id), center_(center), half_u_(half_u), half_v_(half_v) {
  if (!(u.norm() > 1e-12) || !(half_u > 0) || !(half_v > 0))
    throw std::invalid_argument("Quad: axes must be non-zero and half sizes positive");
  u_ = u.normalized();
  v_ = v - v.dot(u_) * u_;
  if (!(v_.norm() > 1e-12)) throw std::invalid_argument("Quad: axes u and v are parallel");
  v_.normalize();
  normal_ = u_.cross(v_);
}

std::optional<double> Quad::intersect(const Ray& ray, double t_max) const {
  const double denom = normal_.dot(ray.dir);
  if (std::abs(denom) < 1e-15) return std::nullopt;
  const double t = normal_.dot(center_ - ray.origin) / denom;
  if (!(t > kRayEpsilon && t < t_max)) return std::nullopt;
  const Eigen::Vector3d p = ray.origin + t * ray.dir - center_;
  if (std::abs(p.dot(u_)) > half_u_ || std::abs(p.dot(v_)) > half_v_) return std::nullopt;
  return t;
}

Eigen::AlignedBox3d Quad::bounds() const {
  const Eigen::Vector3d ext = half_u_ * u_.cwiseAbs() + half_v_ * v_.cwiseAbs();
  return Eigen::AlignedBox3d(center_ - ext, center_ + ext);
}

// ------------------------------------------------------------------------------------------
OrientedBox::OrientedBox(const Eigen::Vector3d& center, const Eigen::Matrix3d& R,
                         const Eigen::Vector3d& half_extents, int object_id)
    : Primitive(object_id), center_(center), R_(R), half_(half_extents) {
  if (!(half_extents.minCoeff() > 0))
    throw std::invalid_argument("OrientedBox: half extents must be positive");
}

std::optional<double> OrientedBox::intersect(const Ray& ray, double t_max) const {
  const Eigen::Vector3d o = R_.transpose() * (ray.origin - center_);
  const Eigen::Vector3d d = R_.transpose() * ray.dir;
  double t0, t1;
  if (!rayAabb(o, d, -half_, half_, &t0, &t1)) return std::nullopt;
  if (auto t = accept(t0, t_max)) return t;
  return accept(t1, t_max);  // origin inside: the exit face
}

Eigen::AlignedBox3d OrientedBox::bounds() const { return transformedBox(center_, R_, half_); }

// ------------------------------------------------------------------------------------------
Cylinder::Cylinder(const Eigen::Vector3d& center, const Eigen::Matrix3d& R, double radius,
                   double half_height, int object_id)
    : Primitive(object_id), center_(center), R_(R), radius_(radius), half_height_(half_height) {
  if (!(radius > 0) || !(half_height > 0))
    throw std::invalid_argument("Cylinder: radius and half height must be positive");
}

std::optional<double> Cylinder::intersect(const Ray& ray, double t_max) const {
  const Eigen::Vector3d o = R_.transpose() * (ray.origin - center_);
  const Eigen::Vector3d d = R_.transpose() * ray.dir;
  double best = t_max;
  bool found = false;
  auto consider = [&](double t) {
    if (t > kRayEpsilon && t < best) {
      best = t;
      found = true;
    }
  };
  // Side: x^2 + y^2 = r^2 with |z| <= h.
  const double a = d.x() * d.x() + d.y() * d.y();
  if (a > 1e-18) {
    const double b = o.x() * d.x() + o.y() * d.y();
    const double c = o.x() * o.x() + o.y() * o.y() - radius_ * radius_;
    const double disc = b * b - a * c;
    if (disc >= 0) {
      const double s = std::sqrt(disc);
      for (double t : {(-b - s) / a, (-b + s) / a})
        if (std::abs(o.z() + t * d.z()) <= half_height_) consider(t);
    }
  }
  // Caps: z = +-h with x^2 + y^2 <= r^2.
  if (std::abs(d.z()) > 1e-15) {
    for (double z : {-half_height_, half_height_}) {
      const double t = (z - o.z()) / d.z();
      const double x = o.x() + t * d.x(), y = o.y() + t * d.y();
      if (x * x + y * y <= radius_ * radius_) consider(t);
    }
  }
  if (!found) return std::nullopt;
  return best;
}

Eigen::AlignedBox3d Cylinder::bounds() const {
  return transformedBox(center_, R_, Eigen::Vector3d(radius_, radius_, half_height_));
}

// ------------------------------------------------------------------------------------------
Sphere::Sphere(const Eigen::Vector3d& center, double radius, int object_id)
    : Primitive(object_id), center_(center), radius_(radius) {
  if (!(radius > 0)) throw std::invalid_argument("Sphere: radius must be positive");
}

std::optional<double> Sphere::intersect(const Ray& ray, double t_max) const {
  const Eigen::Vector3d oc = ray.origin - center_;
  const double b = oc.dot(ray.dir);
  const double c = oc.squaredNorm() - radius_ * radius_;
  const double disc = b * b - c;
  if (disc < 0) return std::nullopt;
  const double s = std::sqrt(disc);
  if (auto t = accept(-b - s, t_max)) return t;
  return accept(-b + s, t_max);
}

Eigen::AlignedBox3d Sphere::bounds() const {
  return Eigen::AlignedBox3d(center_ - Eigen::Vector3d::Constant(radius_),
                             center_ + Eigen::Vector3d::Constant(radius_));
}

// ------------------------------------------------------------------------------------------
Superellipsoid::Superellipsoid(const Superquadric& sq, int object_id)
    : Primitive(object_id), sq_(sq), R_(sq.rotation()) {
  if (!(sq.a.minCoeff() > 0))
    throw std::invalid_argument("Superellipsoid: sizes a1, a2, a3 must be positive");
  if (!(sq.e1 >= 0.05 && sq.e1 <= 2.0 && sq.e2 >= 0.05 && sq.e2 <= 2.0))
    throw std::invalid_argument("Superellipsoid: exponents must lie in [0.05, 2], got e1=" +
                                std::to_string(sq.e1) + " e2=" + std::to_string(sq.e2));
}

double Superellipsoid::gauge(const Eigen::Vector3d& p) const {
  // F(x)^(e1/2) with F of eq. 2: ((x/a1)^(2/e2) + (y/a2)^(2/e2))^(e2/e1) + (z/a3)^(2/e1).
  const double x = std::abs(p.x()) / sq_.a.x();
  const double y = std::abs(p.y()) / sq_.a.y();
  const double z = std::abs(p.z()) / sq_.a.z();
  const double xy = std::pow(x, 2.0 / sq_.e2) + std::pow(y, 2.0 / sq_.e2);
  const double f = std::pow(xy, sq_.e2 / sq_.e1) + std::pow(z, 2.0 / sq_.e1);
  return std::pow(f, 0.5 * sq_.e1);
}

double Superellipsoid::insideOutside(const Eigen::Vector3d& p_world) const {
  return std::pow(gauge(R_.transpose() * (p_world - sq_.position)), 2.0 / sq_.e1);
}

std::optional<double> Superellipsoid::intersect(const Ray& ray, double t_max) const {
  const Eigen::Vector3d o = R_.transpose() * (ray.origin - sq_.position);
  const Eigen::Vector3d d = R_.transpose() * ray.dir;
  // The body lies inside [-a, a]: clip the ray to it (slightly inflated for round-off).
  const Eigen::Vector3d box = sq_.a * (1.0 + 1e-9);
  double t_enter, t_exit;
  if (!rayAabb(o, d, -box, box, &t_enter, &t_exit)) return std::nullopt;
  const double lo = std::max(t_enter, kRayEpsilon);
  const double hi = std::min(t_exit, t_max);
  if (!(lo < hi)) return std::nullopt;

  auto g = [&](double t) { return gauge(o + t * d) - 1.0; };
  const double g_lo = g(lo);
  if (g_lo == 0.0) return lo;
  if (g_lo < 0.0) {
    // The ray starts inside the body: report the exit, where g becomes positive again.
    const double g_hi = g(hi);
    if (!(g_hi > 0.0)) return std::nullopt;  // exit lies beyond t_max
    return accept(bracketedRoot(g, lo, g_lo, hi, g_hi), t_max);
  }
  // g is convex along the ray: golden-section search for its minimum, stopping at the first
  // point inside; no such point (to 1e-9 m) means a miss or a tangent graze.
  constexpr double kInvPhi = 0.6180339887498949;
  double a = lo, b = hi;
  double c = b - kInvPhi * (b - a), e = a + kInvPhi * (b - a);
  double gc = g(c), ge = g(e);
  double t_in = -1.0, g_in = 0.0;
  for (int it = 0; it < 100; ++it) {
    if (gc < 0.0) {
      t_in = c;
      g_in = gc;
      break;
    }
    if (ge < 0.0) {
      t_in = e;
      g_in = ge;
      break;
    }
    if (b - a < 1e-9) break;
    if (gc < ge) {
      b = e;
      e = c;
      ge = gc;
      c = b - kInvPhi * (b - a);
      gc = g(c);
    } else {
      a = c;
      c = e;
      gc = ge;
      e = a + kInvPhi * (b - a);
      ge = g(e);
    }
  }
  if (t_in < 0.0) return std::nullopt;
  // Exactly one root in [lo, t_in] since g is convex, positive at lo and negative at t_in.
  return accept(bracketedRoot(g, lo, g_lo, t_in, g_in), t_max);
}

Eigen::AlignedBox3d Superellipsoid::bounds() const {
  return transformedBox(sq_.position, R_, sq_.a);
}

}  // namespace sim
}  // namespace novelty_detection
