#include "novelty_detection/sim/route.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>

#include "layout.h"
#include "novelties.h"

namespace novelty_detection {
namespace sim {

namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kClearanceM = 0.45;  // robot base radius plus a margin

// The route's world: the layout with its doors and furniture as built (nothing moves).
World layoutWorld(const detail::BuiltLayout& layout) {
  World w = layout.static_world;
  for (const auto& door : layout.doors) w.add(detail::makeDoorLeaf(door, door.angle_rad, 0));
  for (const auto& f : layout.furniture) w.add(detail::makeFurniture(f, 0));
  return w;
}

bool clearOfSolids(const detail::BuiltLayout& layout, const Eigen::Vector2d& p, double r) {
  if ((p.array() < layout.free_min.array() + r).any() ||
      (p.array() > layout.free_max.array() - r).any())
    return false;
  for (const auto& s : layout.solids)
    if (detail::footprintDistance(s, p) < r) return false;
  return true;
}

// A floor position near `p` clear of solids: p itself, else moved towards the middle line.
Eigen::Vector2d clearPosition(const detail::BuiltLayout& layout, Eigen::Vector2d p, double mid_y) {
  for (int i = 0; i < 20 && !clearOfSolids(layout, p, kClearanceM); ++i)
    p.y() += 0.1 * (mid_y - p.y()) + (mid_y > p.y() ? 0.02 : -0.02);
  return p;
}

RouteSweep castSweep(const World& world, const Eigen::Vector3d& base, const LaserConfig& laser,
                     std::uint64_t noise_seed) {
  RouteSweep s;
  s.T_world_sensor = sensorPose(base.x(), base.y(), base.z(), laser.mount_height_m);
  TiltScan scan = simulateTiltScan(world, s.T_world_sensor, laser, noise_seed);
  s.cloud = std::move(scan.cloud);
  s.labels = std::move(scan.labels);
  s.lines = std::move(scan.lines);
  s.base_pose = base;
  return s;
}

int countOf(const std::vector<int>& labels, int id) {
  return static_cast<int>(std::count(labels.begin(), labels.end(), id));
}

}  // namespace

void RouteConfig::validate() const {
  auto bad = [](const std::string& what) { throw std::invalid_argument("RouteConfig: " + what); };
  if (reference_sweeps < 2 || reference_sweeps > 40) bad("reference_sweeps must be in [2, 40]");
  if (sequence_sweeps < 1 || sequence_sweeps > 40) bad("sequence_sweeps must be in [1, 40]");
  if (!(current_step_m >= 0.0 && current_step_m <= 1.0)) bad("current_step_m must be in [0, 1]");
  if (!(person_step_m > 0.0 && person_step_m <= 3.0)) bad("person_step_m must be in (0, 3]");
  if (object != NoveltyKind::kBox && object != NoveltyKind::kCylinder &&
      object != NoveltyKind::kSuperellipsoid)
    bad("object must be a box, a cylinder or a superellipsoid");
  if (min_object_points < 1) bad("min_object_points must be >= 1");
  laser.validate();
}

RouteScene generateRoute(const RouteConfig& config) {
  config.validate();
  Rng layout_rng(mixSeed(config.seed, 1));
  const detail::BuiltLayout layout = config.layout == Layout::kCorridor
                                         ? detail::buildCorridor(layout_rng)
                                         : detail::buildOffice(layout_rng);
  Rng rng(mixSeed(config.seed, 2));
  const World world = layoutWorld(layout);
  const double x0 = layout.free_min.x() + 1.0, x1 = layout.free_max.x() - 1.0;
  const double mid_y = 0.5 * (layout.free_min.y() + layout.free_max.y());
  const double half_width = 0.5 * (layout.free_max.y() - layout.free_min.y());
  const double lane = std::min(0.3, 0.5 * half_width);

  RouteScene scene;
  scene.config = config;
  // The route map.
  const int n = config.reference_sweeps;
  std::vector<Eigen::Vector3d> route;
  for (int k = 0; k < n; ++k) {
    const double x = x0 + (x1 - x0) * k / (n - 1);
    const Eigen::Vector2d p = clearPosition(layout, {x, mid_y + uniform(rng, -lane, lane)}, mid_y);
    const double yaw = (k % 2 ? M_PI : 0.0) + uniform(rng, -10.0, 10.0) * kDeg;
    route.emplace_back(p.x(), p.y(), yaw);
    scene.reference.push_back(
        castSweep(world, route.back(), config.laser, mixSeed(config.seed, 100 + k)));
  }

  // The sequence's start: between two route poses, heading along the route towards its
  // farther end (room for the object ahead); the object that stays: ahead of the first pose,
  // on one side (the person walks on the other). A start without a visible placement is
  // drawn again.
  Eigen::Vector2d start = Eigen::Vector2d::Zero();
  double heading = 0.0, dir = 1.0, room_ahead = 0.0, side = 1.0;
  std::vector<Eigen::Vector3d> poses;
  std::vector<PrimitivePtr> object_prims;
  LaserConfig check = config.laser;
  check.noise_variance_m2 = 0.0;
  bool placed = false;
  for (int start_try = 0; start_try < 30 && !placed; ++start_try) {
    const int gap = uniformInt(rng, 0, n - 2);
    start = clearPosition(layout,
                          {0.5 * (route[gap].x() + route[gap + 1].x()),
                           mid_y + uniform(rng, -0.5 * lane, 0.5 * lane)},
                          mid_y);
    const double ahead_pos = layout.free_max.x() - start.x();
    const double ahead_neg = start.x() - layout.free_min.x();
    heading = ahead_pos >= ahead_neg ? 0.0 : M_PI;
    dir = std::cos(heading);  // +1 along +x, -1 along -x
    room_ahead = std::max(ahead_pos, ahead_neg);
    const double yaw0 = heading + uniform(rng, -8.0, 8.0) * kDeg;
    poses.clear();
    for (int k = 0; k < config.sequence_sweeps; ++k) {
      Eigen::Vector2d p = start + Eigen::Vector2d(dir * config.current_step_m * k, 0.0);
      if (!clearOfSolids(layout, p, kClearanceM))
        p = poses.empty() ? start : Eigen::Vector2d(poses.back().head<2>());
      poses.emplace_back(p.x(), p.y(), yaw0);
    }
    for (int attempt = 0; attempt < 30 && !placed; ++attempt) {
      side = uniform01(rng) < 0.5 ? 1.0 : -1.0;
      const detail::ShapeTemplate shape = detail::sampleShape(config.object, rng);
      const double ahead = uniform(rng, 1.5, std::max(1.6, std::min(5.0, room_ahead - 0.5)));
      const double y = mid_y + side * uniform(rng, 0.2, std::max(0.25, half_width - shape.radius));
      const Eigen::Vector2d c(start.x() + dir * ahead, y);
      if (!clearOfSolids(layout, c, shape.radius + 0.1)) continue;
      bool off_path = true;  // not on the robot's nor on the route's poses
      for (const auto& q : poses) off_path &= (q.head<2>() - c).norm() > shape.radius + kClearanceM;
      for (const auto& q : route) off_path &= (q.head<2>() - c).norm() > shape.radius + kClearanceM;
      if (!off_path) continue;
      ObjectDescription desc;
      desc.id = kStayingObjectId;
      desc.kind = config.object;
      desc.parts = detail::placeParts(shape.parts, c.x(), c.y(), uniform(rng, -M_PI, M_PI));
      std::vector<PrimitivePtr> prims;
      for (const auto& part : desc.parts) prims.push_back(detail::primitiveOf(part, desc.id));
      World w = world;
      for (const auto& p : prims) w.add(p);
      const RouteSweep first = castSweep(w, poses.front(), check, 0);
      if (countOf(first.labels, desc.id) < config.min_object_points) continue;
      desc.points = countOf(first.labels, desc.id);
      scene.object = desc;
      object_prims = prims;
      placed = true;
    }
  }
  if (!placed)
    throw std::runtime_error("generateRoute: no visible placement for the staying object (seed " +
                             std::to_string(config.seed) + ")");

  // The person: walks towards the robot on the other side of the route, at least 0.25 m
  // beside the robot's path; outside the free space (it came in or went out) it is absent.
  const detail::ShapeTemplate person = detail::sampleShape(NoveltyKind::kPerson, rng);
  const double person_start = std::min(uniform(rng, 5.0, 7.0), room_ahead - person.radius);
  auto personAt = [&](int k, double y) {
    const double along = person_start - config.person_step_m * k - config.current_step_m * k;
    return Eigen::Vector2d(poses[k].x() + dir * along, y);
  };
  // Its lane: the offset on its side (0.25 m + its radius from the robot's path, up to the
  // wall) where it stands clear in the most sweeps (furniture along a wall blocks a lane).
  const double min_offset = 0.25 + person.radius;
  double person_y = start.y() - side * min_offset;
  int most_clear = -1;
  for (double offset = min_offset; offset <= 2.0 * half_width; offset += 0.1) {
    const double y = start.y() - side * offset;
    int clear = 0;
    for (int k = 0; k < config.sequence_sweeps; ++k)
      clear += clearOfSolids(layout, personAt(k, y), person.radius);
    if (clear > most_clear) {
      most_clear = clear;
      person_y = y;
    }
  }
  const double person_yaw = heading + M_PI;
  for (int k = 0; k < config.sequence_sweeps; ++k) {
    World w = world;
    for (const auto& p : object_prims) w.add(p);
    if (config.person) {
      const Eigen::Vector2d at = personAt(k, person_y);
      if (clearOfSolids(layout, at, person.radius)) {
        scene.person_path.push_back(at);
        for (const auto& part : detail::placeParts(person.parts, at.x(), at.y(), person_yaw))
          w.add(detail::primitiveOf(part, kWalkingPersonId));
      }
    }
    scene.sequence.push_back(castSweep(w, poses[k], config.laser, mixSeed(config.seed, 200 + k)));
  }

  // The single-sweep reference: the nearest route sweep that looks the same way.
  const Eigen::Isometry3d& T0 = scene.sequence.front().T_world_sensor;
  double best = std::numeric_limits<double>::infinity();
  for (int k = 0; k < n; ++k) {
    const Eigen::Isometry3d& T = scene.reference[k].T_world_sensor;
    const bool same_way = T.linear().col(0).dot(T0.linear().col(0)) > 0.0;
    const double d = (T.translation() - T0.translation()).norm() + (same_way ? 0.0 : 1e6);
    if (d < best) {
      best = d;
      scene.nearest_reference = k;
    }
  }
  return scene;
}

RouteConfig routeSceneConfig(int index, std::uint64_t suite_seed) {
  if (index < 0) throw std::invalid_argument("routeSceneConfig: negative index");
  RouteConfig c;
  c.seed = mixSeed(suite_seed, 5000 + static_cast<std::uint64_t>(index));
  Rng rng(mixSeed(c.seed, 6));
  c.layout = index % 3 == 2 ? Layout::kOffice : Layout::kCorridor;
  c.reference_sweeps = uniformInt(rng, 8, 20);
  static const NoveltyKind kinds[] = {NoveltyKind::kBox, NoveltyKind::kCylinder,
                                      NoveltyKind::kSuperellipsoid};
  c.object = kinds[index % 3 == 2 ? (index / 3) % 3 : index % 3];
  return c;
}

Cloud mergedReference(const RouteScene& scene, ReferenceViews* views, int only) {
  Cloud merged;
  ReferenceViews v;
  for (std::size_t k = 0; k < scene.reference.size(); ++k) {
    if (only >= 0 && static_cast<int>(k) != only) continue;
    const RouteSweep& s = scene.reference[k];
    v.origins.push_back(s.T_world_sensor.translation().cast<float>());
    const auto index = static_cast<std::uint32_t>(v.origins.size() - 1);
    for (const PointT& p : s.cloud) {
      merged.push_back(p);
      v.sweep.push_back(index);
    }
  }
  if (only >= 0 && !scene.reference.empty()) {
    const RouteSweep& s = scene.reference[std::min<std::size_t>(only, scene.reference.size() - 1)];
    merged.sensor_origin_ = s.cloud.sensor_origin_;
    merged.sensor_orientation_ = s.cloud.sensor_orientation_;
  }
  if (views) *views = std::move(v);
  return merged;
}

}  // namespace sim
}  // namespace novelty_detection
