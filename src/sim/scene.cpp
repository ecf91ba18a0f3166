// Scene pairs: a reference sweep of a layout and a current sweep of the same layout with
// changed objects, each labelled by the id of the object its points lie on.
#include "novelty_detection/sim/scene.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>

#include "layout.h"
#include "novelties.h"

namespace novelty_detection {
namespace sim {
namespace {

constexpr double kDeg = M_PI / 180.0;

struct Circle {
  Eigen::Vector2d center;
  double radius;
};

// The mutable part of a sweep's world: door angles and furniture poses, with the object id
// each currently carries (0 while unchanged).
struct Movables {
  std::vector<double> door_angle;
  std::vector<int> door_id;
  std::vector<detail::FurnitureSpec> furniture;
  std::vector<int> furniture_id;
};

World assemble(const detail::BuiltLayout& layout, const Movables& m,
               const std::vector<std::vector<PrimitivePtr>>& objects,
               const std::vector<std::vector<PrimitivePtr>>& extra = {}) {
  World w = layout.static_world;
  for (std::size_t i = 0; i < layout.doors.size(); ++i)
    w.add(detail::makeDoorLeaf(layout.doors[i], m.door_angle[i], m.door_id[i]));
  for (std::size_t i = 0; i < m.furniture.size(); ++i)
    w.add(detail::makeFurniture(m.furniture[i], m.furniture_id[i]));
  for (const auto& obj : objects)
    for (const auto& p : obj) w.add(p);
  for (const auto& obj : extra)
    for (const auto& p : obj) w.add(p);
  return w;
}

// The localisation error as a sensor-frame transform: translation, then roll-pitch-yaw
// R = Rz(yaw) Ry(pitch) Rx(roll).
Eigen::Isometry3d errorInSensorFrame(const Eigen::Matrix<double, 6, 1>& e) {
  Eigen::Isometry3d E = Eigen::Isometry3d::Identity();
  E.translation() = e.head<3>();
  E.linear() = (Eigen::AngleAxisd(e(5), Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(e(4), Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(e(3), Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  return E;
}

// A floor position for a circle of radius r: inside the free area, clear of obstacles and
// placed objects, off the robot's footprint, and in view of the current sensor.
bool samplePlacement(Rng& rng, const detail::BuiltLayout& layout, const std::vector<Circle>& placed,
                     const Eigen::Vector3d& base_ref, const Eigen::Vector3d& base_cur, double r,
                     double max_distance, Eigen::Vector2d* out) {
  const Eigen::Vector2d lo = layout.free_min.array() + r, hi = layout.free_max.array() - r;
  if ((lo.array() >= hi.array()).any()) return false;
  for (int attempt = 0; attempt < 200; ++attempt) {
    const Eigen::Vector2d c(uniform(rng, lo.x(), hi.x()), uniform(rng, lo.y(), hi.y()));
    const Eigen::Vector2d rel = c - base_cur.head<2>();
    if (rel.norm() > max_distance) continue;
    if ((c - base_ref.head<2>()).norm() < r + 0.8 || rel.norm() < r + 0.8) continue;
    const double bearing = std::remainder(std::atan2(rel.y(), rel.x()) - base_cur.z(), 2 * M_PI);
    if (std::abs(bearing) > 120.0 * kDeg) continue;
    bool ok = true;
    for (const auto& o : layout.obstacles)
      if (detail::footprintDistance(o, c) < r + 0.1) ok = false;
    for (const auto& p : placed)
      if ((p.center - c).norm() < p.radius + r + 0.1) ok = false;
    if (!ok) continue;
    *out = c;
    return true;
  }
  return false;
}

std::map<int, int> countLabels(const std::vector<int>& labels) {
  std::map<int, int> counts;
  for (int l : labels)
    if (l > 0) ++counts[l];
  return counts;
}

}  // namespace

std::string toString(Layout layout) { return layout == Layout::kCorridor ? "corridor" : "office"; }

std::string toString(NoveltyKind kind) {
  switch (kind) {
    case NoveltyKind::kBox:
      return "box";
    case NoveltyKind::kCylinder:
      return "cylinder";
    case NoveltyKind::kSphere:
      return "sphere";
    case NoveltyKind::kSuperellipsoid:
      return "superellipsoid";
    case NoveltyKind::kPerson:
      return "person";
    case NoveltyKind::kMovedObject:
      return "moved_object";
    case NoveltyKind::kDoorAngle:
      return "door";
    case NoveltyKind::kRemovedObject:
      return "removed_object";
  }
  return "unknown";
}

Layout layoutFromString(const std::string& name) {
  if (name == "corridor") return Layout::kCorridor;
  if (name == "office") return Layout::kOffice;
  throw std::invalid_argument("unknown layout '" + name + "' (expected corridor or office)");
}

const std::vector<NoveltyKind>& allNoveltyKinds() {
  static const std::vector<NoveltyKind> kinds = {
      NoveltyKind::kBox,      NoveltyKind::kCylinder,
      NoveltyKind::kSphere,   NoveltyKind::kSuperellipsoid,
      NoveltyKind::kPerson,   NoveltyKind::kMovedObject,
      NoveltyKind::kDoorAngle};
  return kinds;
}

const std::vector<NoveltyKind>& everyNoveltyKind() {
  static const std::vector<NoveltyKind> kinds = [] {
    std::vector<NoveltyKind> k = allNoveltyKinds();
    k.push_back(NoveltyKind::kRemovedObject);
    return k;
  }();
  return kinds;
}

NoveltyKind noveltyKindFromString(const std::string& name) {
  for (NoveltyKind k : everyNoveltyKind())
    if (toString(k) == name) return k;
  throw std::invalid_argument("unknown novelty kind '" + name +
                              "' (expected box, cylinder, sphere, superellipsoid, person, "
                              "moved_object, door or removed_object)");
}

void SceneConfig::validate() const {
  laser.validate();
  if (novelty_kinds.empty() && (novelty_count < 0 || novelty_count > 10))
    throw std::invalid_argument("SceneConfig: novelty_count must lie in [0, 10]");
  if (novelty_kinds.size() > 10)
    throw std::invalid_argument("SceneConfig: at most 10 novelty kinds");
  if (!pose_offset.allFinite() || pose_offset.head<2>().norm() > 1.0 ||
      std::abs(pose_offset.z()) > M_PI / 4)
    throw std::invalid_argument(
        "SceneConfig: pose_offset must be finite, within 1 m and 45 deg of the reference");
  if (!localisation_error.allFinite() || localisation_error.head<3>().norm() > 0.5 ||
      localisation_error.tail<3>().cwiseAbs().maxCoeff() > 20.0 * kDeg)
    throw std::invalid_argument(
        "SceneConfig: localisation_error must be finite, within 0.5 m and 20 deg per axis");
  if (!(max_object_distance_m >= 2.0))
    throw std::invalid_argument("SceneConfig: max_object_distance_m must be >= 2");
  if (min_object_points < 1) throw std::invalid_argument("SceneConfig: min_object_points < 1");
  if (max_placement_attempts < 1)
    throw std::invalid_argument("SceneConfig: max_placement_attempts < 1");
}

ScenePair generateScenePair(const SceneConfig& config) {
  config.validate();
  Rng layout_rng(mixSeed(config.seed, 1));
  const detail::BuiltLayout layout = config.layout == Layout::kCorridor
                                         ? detail::buildCorridor(layout_rng)
                                         : detail::buildOffice(layout_rng);
  Rng rng(mixSeed(config.seed, 2));

  std::vector<NoveltyKind> kinds = config.novelty_kinds;
  if (kinds.empty()) {
    Rng kind_rng(mixSeed(config.seed, 5));
    const auto& all = allNoveltyKinds();
    for (int i = 0; i < config.novelty_count; ++i)
      kinds.push_back(all[uniformInt(kind_rng, 0, static_cast<int>(all.size()) - 1)]);
  }

  const double h = config.laser.mount_height_m;
  const Eigen::Vector3d base_ref = layout.base_pose;
  const Eigen::Vector2d d = Eigen::Rotation2Dd(base_ref.z()) * config.pose_offset.head<2>();
  const Eigen::Vector3d base_cur(base_ref.x() + d.x(), base_ref.y() + d.y(),
                                 base_ref.z() + config.pose_offset.z());
  // The robot must stand in the room, not in a wall or a piece of furniture.
  const Eigen::Vector2d base_xy = base_cur.head<2>();
  bool free = (base_xy.array() > layout.free_min.array() + 0.3).all() &&
              (base_xy.array() < layout.free_max.array() - 0.3).all();
  for (const auto& solid : layout.solids)
    if (detail::footprintDistance(solid, base_xy) < 0.3) free = false;
  if (!free)
    throw std::invalid_argument(
        "SceneConfig: pose_offset puts the current sensor within 0.3 m of a wall or of "
        "furniture in this layout");
  const Eigen::Isometry3d T_ref = sensorPose(base_ref.x(), base_ref.y(), base_ref.z(), h);
  const Eigen::Isometry3d T_cur = sensorPose(base_cur.x(), base_cur.y(), base_cur.z(), h);

  Movables ref_state;
  for (const auto& door : layout.doors) ref_state.door_angle.push_back(door.angle_rad);
  ref_state.door_id.assign(layout.doors.size(), 0);
  ref_state.furniture = layout.furniture;
  ref_state.furniture_id.assign(layout.furniture.size(), 0);
  Movables cur_state = ref_state;

  std::vector<std::vector<PrimitivePtr>> object_prims;
  // Removed objects: in the reference world only. They take part in the visibility checks
  // as if present, so the current sensor would have seen them (it sees their place) and
  // the reference sensor does see them.
  std::vector<std::vector<PrimitivePtr>> removed_prims;
  std::vector<ObjectDescription> objects;
  std::vector<Circle> placed;
  LaserConfig check_laser = config.laser;
  check_laser.noise_variance_m2 = 0.0;  // visibility does not depend on noise

  for (NoveltyKind kind : kinds) {
    const int id = static_cast<int>(objects.size()) + 1;
    for (int attempt = 0; attempt < config.max_placement_attempts; ++attempt) {
      Movables state = cur_state;
      std::vector<PrimitivePtr> prims;
      ObjectDescription desc;
      desc.id = id;
      desc.kind = kind;
      Circle circle{Eigen::Vector2d::Zero(), 0.0};
      int door_index = -1;
      double door_ref_angle = 0.0;
      if (kind == NoveltyKind::kDoorAngle) {
        std::vector<int> free_doors;
        for (std::size_t i = 0; i < layout.doors.size(); ++i)
          if (state.door_id[i] == 0) free_doors.push_back(static_cast<int>(i));
        if (free_doors.empty()) break;
        const int di = free_doors[uniformInt(rng, 0, static_cast<int>(free_doors.size()) - 1)];
        // The door's reference state is part of the layout's randomness too: draw both
        // angles in [0, 90] deg, at least 40 deg apart (some pairs leave the leaf hidden in
        // its recess; those fail the visibility test and are redrawn).
        double ref = 0.0, cur = 0.0;
        do {
          ref = uniform(rng, 0.0, 90.0) * kDeg;
          cur = uniform(rng, 0.0, 90.0) * kDeg;
        } while (std::abs(ref - cur) < 40.0 * kDeg);
        door_ref_angle = ref;
        door_index = di;
        state.door_angle[di] = cur;
        state.door_id[di] = id;
        desc.door_angle_reference_rad = ref;
        desc.door_angle_current_rad = cur;
        const auto leaf = detail::makeDoorLeaf(layout.doors[di], cur, id);
        const auto& box = static_cast<const OrientedBox&>(*leaf);
        const Eigen::Matrix3d R = box.rotation();
        desc.parts.push_back(
            detail::boxPart(box.center(), std::atan2(R(1, 0), R(0, 0)), box.halfExtents()));
      } else if (kind == NoveltyKind::kMovedObject) {
        std::vector<int> still;
        for (std::size_t i = 0; i < state.furniture.size(); ++i)
          if (state.furniture_id[i] == 0) still.push_back(static_cast<int>(i));
        if (still.empty()) break;
        const int fi = still[uniformInt(rng, 0, static_cast<int>(still.size()) - 1)];
        detail::FurnitureSpec f = state.furniture[fi];
        desc.reference_pose = Eigen::Vector3d(f.center.x(), f.center.y(), f.yaw);
        circle.radius = f.half.head<2>().norm();
        if (!samplePlacement(rng, layout, placed, base_ref, base_cur, circle.radius,
                             config.max_object_distance_m, &circle.center))
          continue;
        f.center = circle.center;
        f.yaw = std::remainder(f.yaw + uniform(rng, -M_PI, M_PI), 2 * M_PI);
        state.furniture[fi] = f;
        state.furniture_id[fi] = id;
        desc.parts.push_back(detail::boxPart(
            Eigen::Vector3d(f.center.x(), f.center.y(), f.half.z()), f.yaw, f.half));
      } else if (kind == NoveltyKind::kRemovedObject) {
        const NoveltyKind shape_kind =
            uniformInt(rng, 0, 1) == 0 ? NoveltyKind::kBox : NoveltyKind::kCylinder;
        const detail::ShapeTemplate shape = detail::sampleShape(shape_kind, rng);
        circle.radius = shape.radius;
        if (!samplePlacement(rng, layout, placed, base_ref, base_cur, circle.radius,
                             config.max_object_distance_m, &circle.center))
          continue;
        desc.parts = detail::placeParts(shape.parts, circle.center.x(), circle.center.y(),
                                        uniform(rng, -M_PI, M_PI));
        for (const auto& part : desc.parts) prims.push_back(detail::primitiveOf(part, id));
      } else {
        const detail::ShapeTemplate shape = detail::sampleShape(kind, rng);
        circle.radius = shape.radius;
        if (!samplePlacement(rng, layout, placed, base_ref, base_cur, circle.radius,
                             config.max_object_distance_m, &circle.center))
          continue;
        desc.parts = detail::placeParts(shape.parts, circle.center.x(), circle.center.y(),
                                        uniform(rng, -M_PI, M_PI));
        for (const auto& part : desc.parts) prims.push_back(detail::primitiveOf(part, id));
      }
      // Keep it only if it and every object placed before stay visible enough.
      const bool removal = kind == NoveltyKind::kRemovedObject;
      auto candidate_prims = object_prims;
      auto candidate_removed = removed_prims;
      (removal ? candidate_removed : candidate_prims).push_back(prims);
      const World world = assemble(layout, state, candidate_prims, candidate_removed);
      const auto counts = countLabels(simulateTiltScan(world, T_cur, check_laser, 0).labels);
      bool visible = true;
      for (int k = 1; k <= id; ++k) {
        const auto it = counts.find(k);
        if (it == counts.end() || it->second < config.min_object_points) visible = false;
      }
      Movables ref_candidate = ref_state;
      if (door_index >= 0) {
        ref_candidate.door_angle[door_index] = door_ref_angle;
        ref_candidate.door_id[door_index] = id;
      }
      if (kind == NoveltyKind::kMovedObject)
        for (std::size_t i = 0; i < state.furniture_id.size(); ++i)
          if (state.furniture_id[i] == id) ref_candidate.furniture_id[i] = id;
      if (visible && !candidate_removed.empty()) {
        // Every removed object must also stand in the reference sweep's view.
        const World ref_world = assemble(layout, ref_candidate, {}, candidate_removed);
        const auto ref_counts =
            countLabels(simulateTiltScan(ref_world, T_ref, check_laser, 0).labels);
        for (const auto& o : objects)
          if (o.kind == NoveltyKind::kRemovedObject &&
              (!ref_counts.count(o.id) || ref_counts.at(o.id) < config.min_object_points))
            visible = false;
        if (removal && (!ref_counts.count(id) || ref_counts.at(id) < config.min_object_points))
          visible = false;
      }
      if (!visible) continue;
      cur_state = state;
      ref_state = ref_candidate;
      (removal ? removed_prims : object_prims).push_back(prims);
      objects.push_back(desc);
      if (circle.radius > 0) placed.push_back(circle);
      break;
    }
  }

  ScenePair pair;
  pair.config = config;
  pair.config.novelty_kinds = kinds;
  pair.base_pose_reference = base_ref;
  pair.base_pose_current = base_cur;
  pair.T_world_sensor_reference = T_ref;
  pair.T_world_sensor_current = T_cur;
  // Object ids in the reference world only label reference points; geometry and noise
  // draws are those of a world without them.
  pair.reference_world = assemble(layout, ref_state, {}, removed_prims);
  pair.current_world = assemble(layout, cur_state, object_prims);
  TiltScan ref =
      simulateTiltScan(pair.reference_world, T_ref, config.laser, mixSeed(config.seed, 3));
  TiltScan cur = simulateTiltScan(pair.current_world, T_cur, config.laser, mixSeed(config.seed, 4));
  pair.reference = std::move(ref.cloud);
  pair.reference_lines = std::move(ref.lines);
  pair.reference_labels = std::move(ref.labels);
  pair.current = std::move(cur.cloud);
  pair.current_lines = std::move(cur.lines);
  pair.current_labels = std::move(cur.labels);
  pair.current_newly_visible = newlyVisibleMask(pair.reference_world, T_ref, config.laser,
                                                cur.true_points, pair.current_labels);

  // Localisation error: the robot reports T_cur * E for its sensor, so every point (taken
  // in the sensor frame and mapped with the reported pose) lands at T_error * p.
  if (!config.localisation_error.isZero()) {
    pair.T_error = T_cur * errorInSensorFrame(config.localisation_error) * T_cur.inverse();
    for (auto& p : pair.current.points) {
      const Eigen::Vector3d q = pair.T_error * Eigen::Vector3d(p.x, p.y, p.z);
      p.x = static_cast<float>(q.x());
      p.y = static_cast<float>(q.y());
      p.z = static_cast<float>(q.z());
    }
    const Eigen::Isometry3d reported = pair.T_error * T_cur;
    pair.current.sensor_origin_ << reported.translation().cast<float>(), 0.0f;
    pair.current.sensor_orientation_ = Eigen::Quaternionf(reported.linear().cast<float>());
  }

  const auto counts = countLabels(pair.current_labels);
  const auto ref_counts = countLabels(pair.reference_labels);
  for (auto& o : objects) {
    const auto it = counts.find(o.id);
    o.points = it == counts.end() ? 0 : it->second;
    const auto rt = ref_counts.find(o.id);
    o.reference_points = rt == ref_counts.end() ? 0 : rt->second;
  }
  pair.objects = std::move(objects);
  return pair;
}

SceneConfig suiteSceneConfig(int index, std::uint64_t suite_seed) {
  if (index < 0) throw std::invalid_argument("suiteSceneConfig: negative index");
  SceneConfig c;
  c.seed = mixSeed(suite_seed, 1000 + static_cast<std::uint64_t>(index));
  Rng rng(mixSeed(c.seed, 6));
  c.layout = index % 3 == 2 ? Layout::kOffice : Layout::kCorridor;
  const auto& all = allNoveltyKinds();
  const int count = uniformInt(rng, 1, 3);
  // Consecutive scenes start at consecutive kinds, so every kind leads in a suite of 7+.
  for (int j = 0; j < count; ++j) c.novelty_kinds.push_back(all[(index + 3 * j) % all.size()]);
  if (index % 3 == 1) {  // the robot came back to roughly, not exactly, the same spot
    const double m = uniform(rng, 0.05, 0.30), dir = uniform(rng, -M_PI, M_PI);
    c.pose_offset =
        Eigen::Vector3d(m * std::cos(dir), m * std::sin(dir), uniform(rng, -10.0, 10.0) * kDeg);
  }
  return c;
}

}  // namespace sim
}  // namespace novelty_detection
