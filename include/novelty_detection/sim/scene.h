// Simulated scene pairs (reference sweep, current sweep with changes) with exact ground
// truth, for tests, benchmarks and the simulate_scans tool. ROS-free.
//
// Usage:
//   sim::SceneConfig cfg;                 // or sim::suiteSceneConfig(i, suite_seed)
//   cfg.seed = 7;
//   cfg.novelty_kinds = {sim::NoveltyKind::kPerson};
//   sim::ScenePair s = sim::generateScenePair(cfg);
//   // s.reference, s.current: clouds in the world frame (z up, floor at z = 0)
//   // s.current_labels[i]: 0 static, k > 0 id of the changed object point i lies on
#pragma once

#include <Eigen/Geometry>

#include <cstdint>
#include <string>
#include <vector>

#include "novelty_detection/sim/laser.h"
#include "novelty_detection/sim/world.h"
#include "novelty_detection/types.h"

namespace novelty_detection {
namespace sim {

enum class Layout { kCorridor, kOffice };

enum class NoveltyKind {
  kBox,             ///< a box standing on the floor
  kCylinder,        ///< an upright capped cylinder
  kSphere,          ///< a ball lying on the floor
  kSuperellipsoid,  ///< a general superellipsoid, upright or lying on a side
  kPerson,          ///< head, torso, arms, legs, feet
  kMovedObject,     ///< a furniture box of the reference stands elsewhere in the current
  kDoorAngle,       ///< a door leaf whose opening angle changed
};

std::string toString(Layout layout);
std::string toString(NoveltyKind kind);
/// Parses "corridor"/"office" and the kind names of toString ("box", "cylinder", "sphere",
/// "superellipsoid", "person", "moved_object", "door"); throws std::invalid_argument.
Layout layoutFromString(const std::string& name);
NoveltyKind noveltyKindFromString(const std::string& name);
/// All kinds, in declaration order.
const std::vector<NoveltyKind>& allNoveltyKinds();

struct SceneConfig {
  std::uint64_t seed = 1;  ///< drives layout, novelties and noise
  Layout layout = Layout::kCorridor;
  /// Kinds to insert, one object each. When empty, `novelty_count` kinds are drawn from
  /// the seed.
  std::vector<NoveltyKind> novelty_kinds;
  int novelty_count = 1;
  LaserConfig laser;  ///< lines, tilt range, noise variance, mount height, ...
  /// Pose of the current sweep relative to the reference: dx [m], dy [m] in the reference
  /// base frame, dyaw [rad].
  Eigen::Vector3d pose_offset = Eigen::Vector3d::Zero();
  int min_object_points = 50;          ///< placements giving fewer current points are resampled
  double max_object_distance_m = 6.0;  ///< novelties stand at most this far from the sensor
  int max_placement_attempts = 40;     ///< per novelty; a novelty that never fits is left out

  /// Throws std::invalid_argument naming the bad field.
  void validate() const;
};

/// One geometric part of a described object.
struct ObjectPart {
  std::string shape;  ///< "box", "cylinder", "sphere", "superellipsoid"
  /// Its superquadric: exact for spheres and superellipsoids; for boxes (e1 = e2 = 0.1) and
  /// cylinders (e1 = 0.1, e2 = 1) the near-limit superquadric that approximates it.
  Superquadric sq;
  bool sq_exact = false;
};

/// A changed object of the current sweep.
struct ObjectDescription {
  int id = 0;  ///< > 0, the ground-truth label of its points
  NoveltyKind kind = NoveltyKind::kBox;
  std::vector<ObjectPart> parts;  ///< one for simple shapes, several for a person
  int points = 0;                 ///< points of the current sweep on it
  /// Moved object: its reference pose (x, y, yaw) and half extents. Door: hinge position and
  /// angles are in door_* fields.
  Eigen::Vector3d reference_pose = Eigen::Vector3d::Zero();
  double door_angle_reference_rad = 0.0;
  double door_angle_current_rad = 0.0;
};

struct ScenePair {
  SceneConfig config;
  Cloud reference;  ///< world frame, z up, floor at z = 0
  Cloud current;
  Eigen::Isometry3d T_world_sensor_reference = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_world_sensor_current = Eigen::Isometry3d::Identity();
  /// Per point of `current`: 0 static scene, k > 0 id of the changed object hit.
  std::vector<int> current_labels;
  std::vector<ObjectDescription> objects;
  /// The raw lines of each sweep (for LaserScan output); clouds are assembled from them.
  std::vector<LaserLine> reference_lines, current_lines;
  /// The worlds the sweeps were cast in (primitives shared, cheap to copy).
  World reference_world, current_world;
  /// Robot base poses (x, y, yaw) on the floor.
  Eigen::Vector3d base_pose_reference = Eigen::Vector3d::Zero();
  Eigen::Vector3d base_pose_current = Eigen::Vector3d::Zero();
};

/// Builds the layout, inserts the novelties and casts both sweeps. Deterministic for a
/// config. Throws std::invalid_argument for a bad config.
ScenePair generateScenePair(const SceneConfig& config);

/// Varied scenes for a suite: 2 of 3 corridors, the rest offices; 1-3 novelties cycling
/// through all kinds; every third scene has a pose offset of 5-30 cm and up to +-10 deg.
SceneConfig suiteSceneConfig(int index, std::uint64_t suite_seed);

}  // namespace sim
}  // namespace novelty_detection
