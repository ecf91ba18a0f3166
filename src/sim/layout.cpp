// Corridors and offices: walls are two-sided quads with door openings; behind every opening
// a small closed recess (so open doors show a room, not the void); floor and ceiling are
// quads covering everything. Dimensions vary with the seed within realistic ranges.
#include "layout.h"

#include <algorithm>
#include <cmath>

namespace novelty_detection {
namespace sim {
namespace detail {
namespace {

constexpr double kDeg = M_PI / 180.0;

Eigen::Matrix3d yawRotation(double yaw) {
  return Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

// A wall from p0 to p1 between heights z0 and z1.
void addVerticalQuad(World& w, const Eigen::Vector2d& p0, const Eigen::Vector2d& p1, double z0,
                     double z1) {
  const double len = (p1 - p0).norm();
  if (len < 1e-6 || z1 - z0 < 1e-6) return;
  const Eigen::Vector2d mid = 0.5 * (p0 + p1);
  const Eigen::Vector3d u((p1 - p0).x() / len, (p1 - p0).y() / len, 0.0);
  w.add(std::make_shared<Quad>(Eigen::Vector3d(mid.x(), mid.y(), 0.5 * (z0 + z1)), u,
                               Eigen::Vector3d::UnitZ(), 0.5 * len, 0.5 * (z1 - z0)));
}

void addHorizontalQuad(World& w, const Eigen::Vector2d& mn, const Eigen::Vector2d& mx, double z) {
  const Eigen::Vector2d mid = 0.5 * (mn + mx);
  w.add(std::make_shared<Quad>(Eigen::Vector3d(mid.x(), mid.y(), z), Eigen::Vector3d::UnitX(),
                               Eigen::Vector3d::UnitY(), 0.5 * (mx.x() - mn.x()),
                               0.5 * (mx.y() - mn.y())));
}

struct Opening {
  int wall = 0;
  double s = 0.0;  ///< start along the wall [m]
  double width = 0.9, height = 2.05;
  double recess_depth = 1.5, recess_width = 2.4;
  double lo() const { return s + 0.5 * width - 0.5 * recess_width; }
  double hi() const { return s + 0.5 * width + 0.5 * recess_width; }
};

struct WallGeom {
  Eigen::Vector2d p0, dir, inward;
  double length;
};

// Walls of an axis-aligned room, counter-clockwise, inward normal on the left.
WallGeom wallOf(const Eigen::Vector2d& mn, const Eigen::Vector2d& mx, int k) {
  const Eigen::Vector2d c[4] = {
      {mn.x(), mn.y()}, {mx.x(), mn.y()}, {mx.x(), mx.y()}, {mn.x(), mx.y()}};
  WallGeom g;
  g.p0 = c[k];
  const Eigen::Vector2d d = c[(k + 1) % 4] - c[k];
  g.length = d.norm();
  g.dir = d / g.length;
  g.inward = Eigen::Vector2d(-g.dir.y(), g.dir.x());
  return g;
}

// Samples a door opening on a wall whose recess does not overlap the others; false if none
// fits after a few tries.
// When given, [center_min, center_max] bounds the opening's centre along the wall.
bool sampleOpening(Rng& rng, int wall, double wall_length, const std::vector<Opening>& existing,
                   Opening* out, double center_min = 0.0, double center_max = kInfinity) {
  for (int attempt = 0; attempt < 30; ++attempt) {
    Opening o;
    o.wall = wall;
    o.width = uniform(rng, 0.85, 1.0);
    o.height = uniform(rng, 2.0, 2.2);
    o.recess_depth = uniform(rng, 1.3, 2.5);
    o.recess_width = uniform(rng, 2.0, 3.0);
    const double s_min = std::max(0.5 * o.recess_width + 0.05, center_min) - 0.5 * o.width;
    const double s_max =
        std::min(wall_length - 0.5 * o.recess_width - 0.05, center_max) - 0.5 * o.width;
    if (s_max <= s_min) return false;
    o.s = uniform(rng, s_min, s_max);
    bool ok = true;
    for (const auto& e : existing)
      if (e.wall == wall && o.lo() < e.hi() + 0.2 && e.lo() < o.hi() + 0.2) ok = false;
    if (ok) {
      *out = o;
      return true;
    }
  }
  return false;
}

// Walls with openings, recesses, floor, ceiling, doors and the space kept free before doors.
void buildShell(BuiltLayout& out, const Eigen::Vector2d& mn, const Eigen::Vector2d& mx, double H,
                const std::vector<Opening>& openings, bool doors_open_inward, Rng& rng) {
  out.height = H;
  const Eigen::Vector2d margin(3.0, 3.0);
  addHorizontalQuad(out.static_world, mn - margin, mx + margin, 0.0);
  addHorizontalQuad(out.static_world, mn - margin, mx + margin, H);
  for (int k = 0; k < 4; ++k) {
    const WallGeom g = wallOf(mn, mx, k);
    std::vector<Opening> mine;
    for (const auto& o : openings)
      if (o.wall == k) mine.push_back(o);
    std::sort(mine.begin(), mine.end(),
              [](const Opening& a, const Opening& b) { return a.s < b.s; });
    double cursor = 0.0;
    for (const auto& o : mine) {
      const Eigen::Vector2d a = g.p0 + g.dir * o.s, b = g.p0 + g.dir * (o.s + o.width);
      addVerticalQuad(out.static_world, g.p0 + g.dir * cursor, a, 0.0, H);
      addVerticalQuad(out.static_world, a, b, o.height, H);  // lintel
      cursor = o.s + o.width;
      // The recess behind the opening.
      const Eigen::Vector2d out_dir = -g.inward;
      const Eigen::Vector2d ra = g.p0 + g.dir * o.lo(), rb = g.p0 + g.dir * o.hi();
      addVerticalQuad(out.static_world, ra + out_dir * o.recess_depth,
                      rb + out_dir * o.recess_depth, 0.0, H);
      addVerticalQuad(out.static_world, ra, ra + out_dir * o.recess_depth, 0.0, H);
      addVerticalQuad(out.static_world, rb, rb + out_dir * o.recess_depth, 0.0, H);
      // The door leaf, hinged on either side, opening into the recess.
      DoorSpec door;
      const bool hinge_at_start = uniform01(rng) < 0.5;
      door.hinge = hinge_at_start ? a : b;
      door.along = hinge_at_start ? g.dir : Eigen::Vector2d(-g.dir);
      door.into = doors_open_inward ? g.inward : out_dir;
      door.width = o.width - 0.04;
      door.height = o.height - 0.02;
      const double u = uniform01(rng);
      door.angle_rad = u < 0.3 ? 0.0 : (u < 0.6 ? 90.0 * kDeg : uniform(rng, 20.0, 90.0) * kDeg);
      out.doors.push_back(door);
      // Keep the way through the door free.
      Footprint zone;
      // Inward doors need their swing, outward ones a passage of 0.9 m.
      const double depth = doors_open_inward ? o.width + 0.1 : 0.9;
      zone.center = 0.5 * (a + b) + g.inward * (0.5 * depth);
      zone.yaw = std::atan2(g.dir.y(), g.dir.x());
      zone.half = Eigen::Vector2d(0.5 * o.width + 0.15, 0.5 * depth);
      out.obstacles.push_back(zone);
    }
    addVerticalQuad(out.static_world, g.p0 + g.dir * cursor, g.p0 + g.dir * g.length, 0.0, H);
  }
}

bool clearOf(const BuiltLayout& l, const Footprint& f, const Eigen::Vector2d& sensor,
             double sensor_clearance) {
  // Conservative: compare the footprint's bounding circle with the obstacles.
  const double r = f.half.norm() + f.radius;
  for (const auto& o : l.obstacles)
    if (footprintDistance(o, f.center) < r + 0.1) return false;
  return footprintDistance(f, sensor) >= sensor_clearance;
}

void addFurnitureAgainstWalls(BuiltLayout& out, const Eigen::Vector2d& mn,
                              const Eigen::Vector2d& mx, const std::vector<int>& walls, int count,
                              bool office, Rng& rng) {
  const Eigen::Vector2d sensor = out.base_pose.head<2>();
  for (int n = 0; n < count; ++n) {
    for (int attempt = 0; attempt < 30; ++attempt) {
      const int k = walls[uniformInt(rng, 0, static_cast<int>(walls.size()) - 1)];
      const WallGeom g = wallOf(mn, mx, k);
      FurnitureSpec f;
      if (office && uniform01(rng) < 0.5)  // desk
        f.half = Eigen::Vector3d(uniform(rng, 0.6, 0.8), uniform(rng, 0.35, 0.4),
                                 uniform(rng, 0.36, 0.38));
      else if (office)  // cabinet
        f.half = Eigen::Vector3d(uniform(rng, 0.4, 0.6), uniform(rng, 0.2, 0.25),
                                 uniform(rng, 0.5, 1.0));
      else  // bench, bin, shelf
        f.half = Eigen::Vector3d(uniform(rng, 0.3, 0.8), uniform(rng, 0.15, 0.27),
                                 uniform(rng, 0.2, 0.6));
      if (g.length < 2.0 * f.half.x() + 0.2) continue;
      const double s = uniform(rng, f.half.x() + 0.05, g.length - f.half.x() - 0.05);
      f.center = g.p0 + g.dir * s + g.inward * (f.half.y() + 0.02);
      f.yaw = std::atan2(g.dir.y(), g.dir.x());
      const Footprint fp = footprintOf(f);
      bool ok = true;
      for (const auto& o : out.obstacles) {
        // Exact enough for wall-aligned boxes: test the four corners and the centre.
        for (double sx : {-1.0, 0.0, 1.0})
          for (double sy : {-1.0, 0.0, 1.0}) {
            const Eigen::Vector2d c =
                fp.center +
                Eigen::Rotation2Dd(fp.yaw) * Eigen::Vector2d(sx * fp.half.x(), sy * fp.half.y());
            if (footprintDistance(o, c) < 0.1) ok = false;
          }
      }
      if (!ok || footprintDistance(fp, sensor) < 0.7) continue;
      out.furniture.push_back(f);
      out.obstacles.push_back(fp);
      out.solids.push_back(fp);
      break;
    }
  }
}

}  // namespace

double footprintDistance(const Footprint& f, const Eigen::Vector2d& p) {
  const Eigen::Vector2d q = Eigen::Rotation2Dd(-f.yaw) * (p - f.center);
  const Eigen::Vector2d outside = (q.cwiseAbs() - f.half).cwiseMax(0.0);
  return std::max(0.0, outside.norm() - f.radius);
}

PrimitivePtr makeDoorLeaf(const DoorSpec& door, double angle_rad, int object_id) {
  const Eigen::Vector2d leaf = std::cos(angle_rad) * door.along + std::sin(angle_rad) * door.into;
  const Eigen::Vector2d c = door.hinge + 0.02 * door.along + 0.5 * door.width * leaf;
  return std::make_shared<OrientedBox>(
      Eigen::Vector3d(c.x(), c.y(), 0.01 + 0.5 * door.height),
      yawRotation(std::atan2(leaf.y(), leaf.x())),
      Eigen::Vector3d(0.5 * door.width, 0.5 * door.thickness, 0.5 * door.height), object_id);
}

PrimitivePtr makeFurniture(const FurnitureSpec& f, int object_id) {
  return std::make_shared<OrientedBox>(Eigen::Vector3d(f.center.x(), f.center.y(), f.half.z()),
                                       yawRotation(f.yaw), f.half, object_id);
}

Footprint footprintOf(const FurnitureSpec& f) {
  Footprint fp;
  fp.center = f.center;
  fp.yaw = f.yaw;
  fp.half = f.half.head<2>();
  return fp;
}

BuiltLayout buildCorridor(Rng& rng) {
  BuiltLayout out;
  const double L = uniform(rng, 14.0, 22.0), W = uniform(rng, 2.0, 3.0);
  const double H = uniform(rng, 2.5, 3.0);
  const Eigen::Vector2d mn(0.0, -0.5 * W), mx(L, 0.5 * W);
  std::vector<Opening> openings;
  // One door 4-8 m down the corridor from its start (where the robot stands), so that a
  // door change is in view; the others anywhere. Wall 0 runs along +x, wall 2 along -x.
  {
    Opening o;
    const int wall = uniform01(rng) < 0.5 ? 0 : 2;
    const bool ok = wall == 0 ? sampleOpening(rng, wall, L, openings, &o, 4.0, 8.0)
                              : sampleOpening(rng, wall, L, openings, &o, L - 8.0, L - 4.0);
    if (ok) openings.push_back(o);
  }
  for (int wall : {0, 2}) {
    const int n = uniformInt(rng, 0, 2);
    for (int i = 0; i < n; ++i) {
      Opening o;
      if (sampleOpening(rng, wall, L, openings, &o)) openings.push_back(o);
    }
  }
  buildShell(out, mn, mx, H, openings, /*doors_open_inward=*/false, rng);
  out.base_pose = Eigen::Vector3d(uniform(rng, 1.5, 3.0), uniform(rng, -0.15, 0.15),
                                  uniform(rng, -8.0, 8.0) * kDeg);
  // Pillars half sunk into the side walls, floor to ceiling.
  const int pillars = uniformInt(rng, 0, 3);
  for (int n = 0; n < pillars; ++n) {
    for (int attempt = 0; attempt < 20; ++attempt) {
      Footprint fp;
      const double side = uniform01(rng) < 0.5 ? -1.0 : 1.0;
      fp.half = Eigen::Vector2d(uniform(rng, 0.15, 0.25), uniform(rng, 0.15, 0.25));
      fp.center = Eigen::Vector2d(uniform(rng, 0.5, L - 0.5), side * 0.5 * W);
      bool recess_clear = true;
      for (const auto& o : openings) {
        const WallGeom g = wallOf(mn, mx, o.wall);
        const double along = (fp.center - g.p0).dot(g.dir);
        if (std::abs(fp.center.y() - g.p0.y()) < 1e-9 && along > o.lo() - 0.4 &&
            along < o.hi() + 0.4)
          recess_clear = false;
      }
      if (!recess_clear || !clearOf(out, fp, out.base_pose.head<2>(), 1.0)) continue;
      out.static_world.add(std::make_shared<OrientedBox>(
          Eigen::Vector3d(fp.center.x(), fp.center.y(), 0.5 * H), Eigen::Matrix3d::Identity(),
          Eigen::Vector3d(fp.half.x(), fp.half.y(), 0.5 * H)));
      out.obstacles.push_back(fp);
      out.solids.push_back(fp);
      break;
    }
  }
  addFurnitureAgainstWalls(out, mn, mx, {0, 2}, uniformInt(rng, 2, 5), false, rng);
  out.free_min = Eigen::Vector2d(0.3, -0.5 * W + 0.02);
  out.free_max = Eigen::Vector2d(L - 0.3, 0.5 * W - 0.02);
  return out;
}

BuiltLayout buildOffice(Rng& rng) {
  BuiltLayout out;
  const double Lx = uniform(rng, 5.0, 8.5), Ly = uniform(rng, 4.0, 6.5);
  const double H = uniform(rng, 2.6, 3.0);
  const Eigen::Vector2d mn(0.0, 0.0), mx(Lx, Ly);
  std::vector<Opening> openings;
  const int doors = uniformInt(rng, 1, 2);
  for (int i = 0; i < doors; ++i) {
    const int wall = uniformInt(rng, 0, 3);
    Opening o;
    if (sampleOpening(rng, wall, wallOf(mn, mx, wall).length, openings, &o)) openings.push_back(o);
  }
  buildShell(out, mn, mx, H, openings, /*doors_open_inward=*/true, rng);
  out.base_pose = Eigen::Vector3d(uniform(rng, 1.0, 1.6), 0.5 * Ly + uniform(rng, -0.4, 0.4),
                                  uniform(rng, -15.0, 15.0) * kDeg);
  if (uniform01(rng) < 0.5) {  // a round pillar
    for (int attempt = 0; attempt < 20; ++attempt) {
      Footprint fp;
      fp.radius = uniform(rng, 0.15, 0.3);
      fp.center = Eigen::Vector2d(uniform(rng, 0.6, Lx - 0.6), uniform(rng, 0.6, Ly - 0.6));
      if (!clearOf(out, fp, out.base_pose.head<2>(), 1.5)) continue;
      out.static_world.add(
          std::make_shared<Cylinder>(Eigen::Vector3d(fp.center.x(), fp.center.y(), 0.5 * H),
                                     Eigen::Matrix3d::Identity(), fp.radius, 0.5 * H));
      out.obstacles.push_back(fp);
      out.solids.push_back(fp);
      break;
    }
  }
  addFurnitureAgainstWalls(out, mn, mx, {0, 1, 2, 3}, uniformInt(rng, 3, 6), true, rng);
  out.free_min = Eigen::Vector2d(0.02, 0.02);
  out.free_max = Eigen::Vector2d(Lx - 0.02, Ly - 0.02);
  return out;
}

}  // namespace detail
}  // namespace sim
}  // namespace novelty_detection
