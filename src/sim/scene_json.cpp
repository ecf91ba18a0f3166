#include "novelty_detection/sim/scene_json.h"

#include <cmath>

namespace novelty_detection {
namespace sim {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

nlohmann::json vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }
nlohmann::json quat(const Eigen::Quaterniond& q) { return {q.x(), q.y(), q.z(), q.w()}; }

nlohmann::json basePose(const Eigen::Vector3d& p) {
  return {{"x", p.x()}, {"y", p.y()}, {"yaw_deg", p.z() * kRadToDeg}};
}

}  // namespace

nlohmann::json superquadricToJson(const Superquadric& sq) {
  return {{"a", vec(sq.a)},
          {"epsilon", {sq.e1, sq.e2}},
          {"position", vec(sq.position)},
          {"euler", vec(sq.euler)},
          {"orientation", quat(sq.quaternion())}};
}

nlohmann::json poseToJson(const Eigen::Isometry3d& T) {
  return {{"position", vec(T.translation())},
          {"orientation", quat(Eigen::Quaterniond(T.linear()).normalized())}};
}

nlohmann::json sceneToJson(const ScenePair& s) {
  const SceneConfig& c = s.config;
  nlohmann::json kinds = nlohmann::json::array();
  for (NoveltyKind k : c.novelty_kinds) kinds.push_back(toString(k));
  nlohmann::json config = {{"seed", c.seed},
                           {"layout", toString(c.layout)},
                           {"novelty_kinds", kinds},
                           {"pose_offset",
                            {{"x_m", c.pose_offset.x()},
                             {"y_m", c.pose_offset.y()},
                             {"yaw_deg", c.pose_offset.z() * kRadToDeg}}},
                           {"localisation_error",
                            {{"x_m", c.localisation_error(0)},
                             {"y_m", c.localisation_error(1)},
                             {"z_m", c.localisation_error(2)},
                             {"roll_deg", c.localisation_error(3) * kRadToDeg},
                             {"pitch_deg", c.localisation_error(4) * kRadToDeg},
                             {"yaw_deg", c.localisation_error(5) * kRadToDeg}}},
                           {"min_object_points", c.min_object_points},
                           {"max_object_distance_m", c.max_object_distance_m},
                           {"laser",
                            {{"fov_deg", c.laser.fov_deg},
                             {"step_deg", c.laser.step_deg},
                             {"beams_per_line", c.laser.beamsPerLine()},
                             {"lines", c.laser.lines},
                             {"tilt_min_deg", c.laser.tilt_min_deg},
                             {"tilt_max_deg", c.laser.tilt_max_deg},
                             {"min_range_m", c.laser.min_range_m},
                             {"max_range_m", c.laser.max_range_m},
                             {"mount_height_m", c.laser.mount_height_m},
                             {"noise_variance_m2", c.laser.noise_variance_m2}}}};

  std::size_t novel = 0;
  for (int l : s.current_labels) novel += l > 0;
  std::size_t disappeared = 0, newly_visible = 0;
  for (int l : s.reference_labels) disappeared += l > 0;
  for (auto v : s.current_newly_visible) newly_visible += v != 0;

  nlohmann::json objects = nlohmann::json::array();
  for (const ObjectDescription& o : s.objects) {
    nlohmann::json parts = nlohmann::json::array();
    for (const ObjectPart& p : o.parts) {
      nlohmann::json j = superquadricToJson(p.sq);
      j["shape"] = p.shape;
      j["exact"] = p.sq_exact;
      parts.push_back(j);
    }
    nlohmann::json j = {{"id", o.id},
                        {"type", toString(o.kind)},
                        {"points", o.points},
                        {"reference_points", o.reference_points},
                        {"parts", parts}};
    if (o.parts.size() == 1) j["superquadric"] = superquadricToJson(o.parts[0].sq);
    if (o.kind == NoveltyKind::kMovedObject) j["reference_pose"] = basePose(o.reference_pose);
    if (o.kind == NoveltyKind::kDoorAngle) {
      j["door_angle_reference_deg"] = o.door_angle_reference_rad * kRadToDeg;
      j["door_angle_current_deg"] = o.door_angle_current_rad * kRadToDeg;
    }
    objects.push_back(j);
  }

  nlohmann::json removed = nlohmann::json::array();
  for (const ObjectDescription& o : s.objects)
    if (o.kind == NoveltyKind::kRemovedObject) removed.push_back(o.id);
  return {{"frame", "map"},
          {"group", sceneGroup(c)},
          {"config", config},
          {"sensor_reference", poseToJson(s.T_world_sensor_reference)},
          {"sensor_current", poseToJson(s.T_world_sensor_current)},
          {"sensor_current_reported", poseToJson(s.T_error * s.T_world_sensor_current)},
          {"T_error", poseToJson(s.T_error)},
          {"removed_objects", removed},
          {"base_reference", basePose(s.base_pose_reference)},
          {"base_current", basePose(s.base_pose_current)},
          {"points",
           {{"reference", s.reference.size()},
            {"current", s.current.size()},
            {"novel", novel},
            {"disappeared", disappeared},
            {"newly_visible", newly_visible}}},
          {"objects", objects}};
}

}  // namespace sim
}  // namespace novelty_detection
