// Geometric primitives with exact ray intersection, for the scan simulator. ROS-free.
//
// Every primitive answers "nearest t > kRayEpsilon along origin + t * dir, below t_max, or
// none", with dir a unit vector, so t is a range in metres. Each carries an object id:
// 0 for the static scene, k > 0 for the changed object k (it becomes the ground-truth label
// of the points it returns).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <limits>
#include <memory>
#include <optional>
#include <string>

#include "novelty_detection/types.h"

namespace novelty_detection {
namespace sim {

/// Smallest accepted hit distance [m]: avoids re-hitting the surface a ray starts on.
constexpr double kRayEpsilon = 1e-9;
constexpr double kInfinity = std::numeric_limits<double>::infinity();

struct Ray {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d dir = Eigen::Vector3d::UnitX();  ///< unit length
};

class Primitive {
 public:
  explicit Primitive(int object_id) : object_id_(object_id) {}
  virtual ~Primitive() = default;

  /// Nearest intersection distance t in (kRayEpsilon, t_max), or none.
  virtual std::optional<double> intersect(const Ray& ray, double t_max = kInfinity) const = 0;
  /// Axis-aligned world bounds (may be infinite for a plane).
  virtual Eigen::AlignedBox3d bounds() const = 0;
  /// Short type name ("plane", "quad", "box", "cylinder", "sphere", "superellipsoid").
  virtual std::string kind() const = 0;

  int objectId() const { return object_id_; }

 private:
  int object_id_;
};

using PrimitivePtr = std::shared_ptr<const Primitive>;

/// Infinite plane through `point` with normal `normal` (normalised here).
class Plane : public Primitive {
 public:
  Plane(const Eigen::Vector3d& point, const Eigen::Vector3d& normal, int object_id = 0);
  std::optional<double> intersect(const Ray& ray, double t_max = kInfinity) const override;
  Eigen::AlignedBox3d bounds() const override;
  std::string kind() const override { return "plane"; }

 private:
  Eigen::Vector3d point_, normal_;
};

/// Bounded rectangle: centre + s * u + t * v with |s| <= half_u, |t| <= half_v; u, v
/// orthonormal (v is re-orthogonalised against u). Two-sided.
class Quad : public Primitive {
 public:
  Quad(const Eigen::Vector3d& center, const Eigen::Vector3d& u, const Eigen::Vector3d& v,
       double half_u, double half_v, int object_id = 0);
  std::optional<double> intersect(const Ray& ray, double t_max = kInfinity) const override;
  Eigen::AlignedBox3d bounds() const override;
  std::string kind() const override { return "quad"; }

 private:
  Eigen::Vector3d center_, u_, v_, normal_;
  double half_u_, half_v_;
};

/// Oriented box: world = center + R * local, local within [-half, half].
class OrientedBox : public Primitive {
 public:
  OrientedBox(const Eigen::Vector3d& center, const Eigen::Matrix3d& R,
              const Eigen::Vector3d& half_extents, int object_id = 0);
  std::optional<double> intersect(const Ray& ray, double t_max = kInfinity) const override;
  Eigen::AlignedBox3d bounds() const override;
  std::string kind() const override { return "box"; }
  const Eigen::Vector3d& center() const { return center_; }
  const Eigen::Matrix3d& rotation() const { return R_; }
  const Eigen::Vector3d& halfExtents() const { return half_; }

 private:
  Eigen::Vector3d center_;
  Eigen::Matrix3d R_;
  Eigen::Vector3d half_;
};

/// Finite capped cylinder: axis = R's local z through center, |z| <= half_height.
class Cylinder : public Primitive {
 public:
  Cylinder(const Eigen::Vector3d& center, const Eigen::Matrix3d& R, double radius,
           double half_height, int object_id = 0);
  std::optional<double> intersect(const Ray& ray, double t_max = kInfinity) const override;
  Eigen::AlignedBox3d bounds() const override;
  std::string kind() const override { return "cylinder"; }

 private:
  Eigen::Vector3d center_;
  Eigen::Matrix3d R_;
  double radius_, half_height_;
};

class Sphere : public Primitive {
 public:
  Sphere(const Eigen::Vector3d& center, double radius, int object_id = 0);
  std::optional<double> intersect(const Ray& ray, double t_max = kInfinity) const override;
  Eigen::AlignedBox3d bounds() const override;
  std::string kind() const override { return "sphere"; }

 private:
  Eigen::Vector3d center_;
  double radius_;
};

/// Superellipsoid (paper eq. 2) with the pose convention of Superquadric (ZYZ Euler,
/// p_sq = R^T (p - position)). Exponents must lie in [0.05, 2] (convex shapes) and sizes
/// be positive, else std::invalid_argument.
///
/// Ray casting is exact on the implicit surface F(x) = 1: in the canonical frame the ray is
/// clipped to the bounding box [-a, a]; along it g(t) = F^(e1/2) - 1 is the gauge function
/// of a convex body minus one, hence convex and homogeneous of degree 1 (well conditioned,
/// unlike F itself whose exponents reach 2/0.05 = 40). A golden-section search finds a point
/// inside (g < 0) or proves a miss, then Illinois false position brackets the first root to
/// 1e-10 m.
class Superellipsoid : public Primitive {
 public:
  explicit Superellipsoid(const Superquadric& sq, int object_id = 0);
  std::optional<double> intersect(const Ray& ray, double t_max = kInfinity) const override;
  Eigen::AlignedBox3d bounds() const override;
  std::string kind() const override { return "superellipsoid"; }
  const Superquadric& superquadric() const { return sq_; }

  /// The inside-outside function F of eq. 2 at a world point (1 on the surface).
  double insideOutside(const Eigen::Vector3d& p_world) const;

 private:
  double gauge(const Eigen::Vector3d& p_sq) const;  // F^(e1/2), canonical frame

  Superquadric sq_;
  Eigen::Matrix3d R_;
};

/// Slab test of a ray against an axis-aligned box; on overlap returns true and the entry and
/// exit distances (t_enter may be negative when the origin is inside).
bool rayAabb(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
             const Eigen::Vector3d& box_min, const Eigen::Vector3d& box_max, double* t_enter,
             double* t_exit);

}  // namespace sim
}  // namespace novelty_detection
