// Patrol routes: a reference made of many sweeps along a corridor or through an office, and a
// sequence of current sweeps in which an object stays while a person walks through. Exact
// ground truth. ROS-free.
//
// Usage:
//   sim::RouteConfig cfg = sim::routeSceneConfig(i, suite_seed);
//   sim::RouteScene r = sim::generateRoute(cfg);
//   // r.reference[k].cloud: sweep k of the route, world frame, VIEWPOINT = its sensor pose
//   // r.sequence[k].cloud, .labels: current sweeps (kStayingObjectId on the object that
//   //   stays, kWalkingPersonId on the person), each from its own pose
//
// The route: reference_sweeps poses evenly along the free space's long axis (1 m from its
// ends), 0.3 m to either side of its middle line at random, each looking along the route one
// way or the other (alternating, +-10 deg): every place is seen from both sides, and no
// reference sweep is taken where a current one is. The sequence: the robot starts between two
// route poses and moves on towards the route's farther end by current_step_m per sweep; an
// object (box, cylinder or superellipsoid) stands 1.5-5 m ahead of it for the whole sequence;
// a person walks towards the robot on the other side, at least 0.25 m beside its path,
// person_step_m per sweep, from 5-7 m ahead (less in a small room), and is absent from sweeps
// where it would stand outside the free space or in furniture.
#pragma once

#include <Eigen/Geometry>

#include <cstdint>
#include <vector>

#include "novelty_detection/sim/laser.h"
#include "novelty_detection/sim/scene.h"
#include "novelty_detection/types.h"

namespace novelty_detection {
namespace sim {

constexpr int kStayingObjectId = 1;  ///< ground-truth label of the object that stays
constexpr int kWalkingPersonId = 2;  ///< ground-truth label of the walking person

struct RouteConfig {
  std::uint64_t seed = 1;
  Layout layout = Layout::kCorridor;
  int reference_sweeps = 10;               ///< sweeps of the route map, 2-40
  int sequence_sweeps = 5;                 ///< current sweeps, 1-40
  double current_step_m = 0.15;            ///< robot motion between current sweeps [m]
  bool person = true;                      ///< a person walks through the sequence
  double person_step_m = 1.0;              ///< the person's walk between sweeps [m]
  NoveltyKind object = NoveltyKind::kBox;  ///< the staying object: box, cylinder, superellipsoid
  int min_object_points = 50;  ///< the staying object has at least this many points in sweep 0
  LaserConfig laser;

  /// Throws std::invalid_argument naming the bad field.
  void validate() const;
};

struct RouteSweep {
  Cloud cloud;  ///< world frame; sensor_origin_/orientation_ = its sensor pose
  Eigen::Isometry3d T_world_sensor = Eigen::Isometry3d::Identity();
  std::vector<int> labels;  ///< per point: 0 static, kStayingObjectId, kWalkingPersonId
  std::vector<LaserLine> lines;                          ///< the raw lines (for LaserScan output)
  Eigen::Vector3d base_pose = Eigen::Vector3d::Zero();  ///< robot base (x, y, yaw) on the floor
};

struct RouteScene {
  RouteConfig config;
  std::vector<RouteSweep> reference;  ///< the route (labels all 0)
  std::vector<RouteSweep> sequence;   ///< the current sweeps, in time order
  ObjectDescription object;           ///< the object that stays
  /// The person's floor position in each sweep of the sequence where it is present.
  std::vector<Eigen::Vector2d> person_path;
  /// The reference sweep nearest the first current sweep among those looking the same way.
  int nearest_reference = 0;
};

/// Builds the layout, the route and the sequence. Deterministic for a config. Throws
/// std::invalid_argument for a bad config, std::runtime_error when no object placement
/// visible from the first current pose is found.
RouteScene generateRoute(const RouteConfig& config);

/// Route scenes for a suite: 2 of 3 corridors, the rest offices; 8-20 reference sweeps;
/// 5 current sweeps; the staying object cycles through box, cylinder, superellipsoid.
RouteConfig routeSceneConfig(int index, std::uint64_t suite_seed);

/// The merged route map (every sweep's points, in order) and, in `views`, its per-sweep
/// viewpoints. With `only` >= 0, that one sweep alone (a single-sweep reference).
Cloud mergedReference(const RouteScene& scene, ReferenceViews* views, int only = -1);

}  // namespace sim
}  // namespace novelty_detection
