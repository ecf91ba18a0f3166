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
//   // s.reference_labels[i]: 0, or k > 0 id of the object whose reference pose point i lies on
//   // s.current_newly_visible[i]: 1 for a static point the reference sensor could not see
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
  kRemovedObject,   ///< a box or cylinder of the reference that is gone in the current
};

std::string toString(Layout layout);
std::string toString(NoveltyKind kind);
/// Parses "corridor"/"office" and the kind names of toString ("box", "cylinder", "sphere",
/// "superellipsoid", "person", "moved_object", "door", "removed_object"); throws
/// std::invalid_argument.
Layout layoutFromString(const std::string& name);
NoveltyKind noveltyKindFromString(const std::string& name);
/// The kinds that put new points into the current sweep (all but kRemovedObject), in
/// declaration order; the default suite and a seed-drawn `novelty_count` use these.
const std::vector<NoveltyKind>& allNoveltyKinds();
/// Every kind, kRemovedObject included.
const std::vector<NoveltyKind>& everyNoveltyKind();

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
  /// Localisation error of the current sweep: the pose the robot reports for its sensor is
  /// the true one moved by x, y, z [m] and turned by roll, pitch, yaw [rad] (XYZ order) in
  /// the true sensor frame, and the current cloud is delivered in that frame (see
  /// ScenePair::T_error). Zero: exact localisation.
  Eigen::Matrix<double, 6, 1> localisation_error = Eigen::Matrix<double, 6, 1>::Zero();
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
  int reference_points = 0;  ///< points of the reference sweep on its reference pose
};

struct ScenePair {
  SceneConfig config;
  Cloud reference;  ///< world frame, z up, floor at z = 0
  /// In the frame the robot reports (the world frame moved by T_error); sensor_origin_ and
  /// sensor_orientation_ are the reported sensor pose.
  Cloud current;
  Eigen::Isometry3d T_world_sensor_reference = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_world_sensor_current = Eigen::Isometry3d::Identity();  ///< true pose
  /// Localisation error as a world-frame map: a point at true position p is delivered at
  /// T_error * p, and the reported sensor pose is T_error * T_world_sensor_current. A
  /// correction that undoes it is T_error.inverse(). Identity without error.
  Eigen::Isometry3d T_error = Eigen::Isometry3d::Identity();
  /// Per point of `current`: 0 static scene, k > 0 id of the changed object hit.
  std::vector<int> current_labels;
  /// Per point of `reference`: k > 0 when it lies on the reference pose of changed object k
  /// that is gone from there in the current world (a removed object, the old place of a
  /// moved object, the old angle of a door leaf), else 0. Whether the current sensor sees
  /// that place is not considered here.
  std::vector<int> reference_labels;
  /// Per point of `current`: 1 for a static point (label 0) the reference sensor could not
  /// see: its ray from the reference sensor origin is blocked before it in the reference
  /// world, or it lies outside the reference laser's tilt/azimuth range or range limits.
  /// Computed on the noise-free position with the exact ray caster.
  std::vector<std::uint8_t> current_newly_visible;
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

/// Scene groups of the viewpoint suite (and of any config): "localisation_error" when the
/// config has a localisation error, else "pose_offset" when it has a pose offset, else
/// "same_pose".
std::string sceneGroup(const SceneConfig& config);

/// Scenes for viewpoint robustness: index % 3 cycles the groups same_pose,
/// pose_offset (5-30 cm, up to +-10 deg, exact localisation) and localisation_error (same
/// pose, error of 1-2.5 cm in x-y, up to 1 cm in z, 0.2-0.8 deg yaw, up to 0.4 deg
/// roll and pitch). Every other triple of scenes has a removed object (half of the scenes,
/// each group alike), alone or with one appearance; the others have 1-2 appearances.
SceneConfig viewpointSceneConfig(int index, std::uint64_t suite_seed);

/// The newly-visible mask for points of a sweep (one per point, world frame, noise-free):
/// 1 where labels[i] == 0 and the reference sensor at T_world_sensor_reference with
/// `laser` could not see points[i] in `reference_world` (see
/// ScenePair::current_newly_visible). A hit within `tolerance_m` before the point counts as
/// the point's own surface.
std::vector<std::uint8_t> newlyVisibleMask(const World& reference_world,
                                           const Eigen::Isometry3d& T_world_sensor_reference,
                                           const LaserConfig& laser,
                                           const std::vector<Eigen::Vector3d>& points,
                                           const std::vector<int>& labels,
                                           double tolerance_m = 1e-3);

}  // namespace sim
}  // namespace novelty_detection
