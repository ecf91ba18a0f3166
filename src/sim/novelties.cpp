#include "novelties.h"

#include <cmath>
#include <stdexcept>

namespace novelty_detection {
namespace sim {
namespace detail {
namespace {

ObjectPart makePart(const std::string& shape, const Eigen::Vector3d& a, double e1, double e2,
                    const Eigen::Vector3d& position, const Eigen::Vector3d& euler, bool exact) {
  ObjectPart p;
  p.shape = shape;
  p.sq.a = a;
  p.sq.e1 = e1;
  p.sq.e2 = e2;
  p.sq.position = position;
  p.sq.euler = euler;
  p.sq_exact = exact;
  return p;
}

ObjectPart superPart(const Eigen::Vector3d& a, double e1, double e2, const Eigen::Vector3d& pos) {
  return makePart("superellipsoid", a, e1, e2, pos, Eigen::Vector3d::Zero(), true);
}

// A standing person (paper Fig. 6-b: head, trunk, two arms, two legs, two feet), sizes
// scaled from a body height h.
ShapeTemplate samplePerson(Rng& rng) {
  ShapeTemplate t;
  const double h = uniform(rng, 1.6, 1.9);
  const double foot_h = 0.08, leg_len = 0.47 * h - foot_h, torso_h = 0.30 * h;
  const double hip_z = foot_h + leg_len, torso_top = hip_z + torso_h;
  const double shoulder_half = uniform(rng, 0.17, 0.21), arm_len = 0.33 * h - 0.03;
  for (double side : {-1.0, 1.0}) {
    t.parts.push_back(boxPart(Eigen::Vector3d(0.04, side * 0.1, 0.5 * foot_h), 0.0,
                              Eigen::Vector3d(0.13, 0.05, 0.5 * foot_h)));
    t.parts.push_back(superPart(Eigen::Vector3d(0.075, 0.075, 0.5 * leg_len), 0.4, 1.0,
                                Eigen::Vector3d(0.0, side * 0.1, foot_h + 0.5 * leg_len)));
    t.parts.push_back(superPart(
        Eigen::Vector3d(0.05, 0.05, 0.5 * arm_len), 0.4, 1.0,
        Eigen::Vector3d(0.0, side * (shoulder_half + 0.065), torso_top - 0.04 - 0.5 * arm_len)));
  }
  t.parts.push_back(superPart(Eigen::Vector3d(0.12, shoulder_half, 0.5 * torso_h), 0.5, 0.5,
                              Eigen::Vector3d(0.0, 0.0, hip_z + 0.5 * torso_h)));
  t.parts.push_back(superPart(Eigen::Vector3d(0.095, 0.08, 0.115), 1.0, 1.0,
                              Eigen::Vector3d(0.0, 0.0, torso_top + 0.04 + 0.115)));
  t.radius = shoulder_half + 0.12;
  return t;
}

}  // namespace

ObjectPart boxPart(const Eigen::Vector3d& center, double yaw, const Eigen::Vector3d& half) {
  return makePart("box", half, 0.1, 0.1, center, Eigen::Vector3d(yaw, 0.0, 0.0), false);
}

ShapeTemplate sampleShape(NoveltyKind kind, Rng& rng) {
  ShapeTemplate t;
  switch (kind) {
    case NoveltyKind::kBox: {
      const Eigen::Vector3d half(uniform(rng, 0.15, 0.45), uniform(rng, 0.15, 0.45),
                                 uniform(rng, 0.15, 0.5));
      t.parts.push_back(boxPart(Eigen::Vector3d(0, 0, half.z()), 0.0, half));
      t.radius = half.head<2>().norm();
      break;
    }
    case NoveltyKind::kCylinder: {
      const double r = uniform(rng, 0.12, 0.35), hh = uniform(rng, 0.2, 0.6);
      t.parts.push_back(makePart("cylinder", Eigen::Vector3d(r, r, hh), 0.1, 1.0,
                                 Eigen::Vector3d(0, 0, hh), Eigen::Vector3d::Zero(), false));
      t.radius = r;
      break;
    }
    case NoveltyKind::kSphere: {
      const double r = uniform(rng, 0.2, 0.45);
      t.parts.push_back(makePart("sphere", Eigen::Vector3d::Constant(r), 1.0, 1.0,
                                 Eigen::Vector3d(0, 0, r), Eigen::Vector3d::Zero(), true));
      t.radius = r;
      break;
    }
    case NoveltyKind::kSuperellipsoid: {
      const Eigen::Vector3d a(uniform(rng, 0.15, 0.45), uniform(rng, 0.15, 0.45),
                              uniform(rng, 0.15, 0.45));
      const double e1 = uniform(rng, 0.2, 1.8), e2 = uniform(rng, 0.2, 1.8);
      // The body lies in [-a, a] and touches each face at (+-a_i) on the axes, so its lowest
      // point sits exactly a3 (upright) or a1 (on its side: canonical x points down) below
      // the centre.
      if (uniform01(rng) < 0.5) {
        t.parts.push_back(makePart("superellipsoid", a, e1, e2, Eigen::Vector3d(0, 0, a.z()),
                                   Eigen::Vector3d::Zero(), true));
        t.radius = a.head<2>().norm();
      } else {
        t.parts.push_back(makePart("superellipsoid", a, e1, e2, Eigen::Vector3d(0, 0, a.x()),
                                   Eigen::Vector3d(0.0, 0.5 * M_PI, 0.0), true));
        t.radius = a.tail<2>().norm();
      }
      break;
    }
    case NoveltyKind::kPerson:
      return samplePerson(rng);
    default:
      throw std::invalid_argument("sampleShape: kind " + toString(kind) + " is not a shape");
  }
  return t;
}

std::vector<ObjectPart> placeParts(const std::vector<ObjectPart>& parts, double x, double y,
                                   double yaw) {
  const Eigen::Matrix3d Rz = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  std::vector<ObjectPart> out = parts;
  for (auto& p : out) {
    p.sq.position = Eigen::Vector3d(x, y, 0.0) + Rz * p.sq.position;
    // ZYZ: Rz(yaw) * Rz(phi) Ry(theta) Rz(psi) = Rz(yaw + phi) Ry(theta) Rz(psi).
    p.sq.euler.x() = std::remainder(p.sq.euler.x() + yaw, 2.0 * M_PI);
  }
  return out;
}

PrimitivePtr primitiveOf(const ObjectPart& part, int object_id) {
  const Superquadric& sq = part.sq;
  if (part.shape == "box")
    return std::make_shared<OrientedBox>(sq.position, sq.rotation(), sq.a, object_id);
  if (part.shape == "cylinder")
    return std::make_shared<Cylinder>(sq.position, sq.rotation(), sq.a.x(), sq.a.z(), object_id);
  if (part.shape == "sphere") return std::make_shared<Sphere>(sq.position, sq.a.x(), object_id);
  if (part.shape == "superellipsoid") return std::make_shared<Superellipsoid>(sq, object_id);
  throw std::invalid_argument("primitiveOf: unknown shape '" + part.shape + "'");
}

}  // namespace detail
}  // namespace sim
}  // namespace novelty_detection
