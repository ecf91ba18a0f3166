// Semi-real scenes: a real object inserted into a real scan along the scanner's own beams.
// ROS-free; test and evaluation data, not part of the detector.
//
// A real sweep holds no known change, and a simulated one lacks the real sensor's noise,
// self-returns and clutter. A semi-real scene keeps the real sweep and adds a known change:
// an object cloud (a person cut from a real camera frame, or a sampled box) is placed on a
// free patch of floor and ray-cast into the sweep. Every beam of the sweep whose ray passes
// the object's surface before its own return is cut there: its point moves onto the object
// (the return it would have given) and is the ground truth; the points the object hides are
// gone, as they would be. Beams the object does not cross are unchanged.
//
// Frames: the scan is z-up (REP 103) with its sensor at `sensor`; an object model has its
// base on z = 0, its vertical axis on +z, its footprint centred on x = y = 0, and the side
// its source camera saw facing -x. A placement turns that side toward the sensor.
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

#include "novelty_detection/types.h"

namespace novelty_detection {
namespace sim {

/// An object cloud in its model frame (see the file comment).
struct ObjectModel {
  Cloud points;
  double height = 0.0;   ///< top above the base [m]
  double radius = 0.0;   ///< largest horizontal distance from the vertical axis [m]
  double spacing = 0.0;  ///< surface sample spacing [m]
  std::string name;
};

/// The person nearest the camera in an organised camera-frame cloud (x right, y down, z
/// forward; e.g. a people-detection test frame): the floor is the largest plane within 30
/// degrees of -y, the person the nearest connected group of points 1.3-2.1 m tall and at
/// most 1 m wide standing on it, resampled on a `spacing` grid. Throws std::runtime_error
/// when no floor or no such group is found.
ObjectModel cutNearestPerson(const Cloud& camera_cloud, double spacing = 0.01);

/// A closed box (no bottom face) of size (x, y, z) sampled every `spacing` metres.
ObjectModel boxModel(const Eigen::Vector3d& size, double spacing = 0.01);

/// Where an object stands: its base point (on the floor) and its turn about +z.
struct Placement {
  Eigen::Vector3d base = Eigen::Vector3d::Zero();
  double yaw = 0.0;  ///< [rad]
};

/// The model's points at `where`, in the scan frame.
Cloud placeModel(const ObjectModel& model, const Placement& where);

/// A sweep with an object ray-cast into it.
struct Insertion {
  Cloud cloud;             ///< same size and order as the input sweep
  std::vector<int> truth;  ///< 1 for each point moved onto the object, else 0
  std::size_t replaced = 0;
};

/// Cuts every beam of `scan` (sensor at `sensor`) that passes within `hit_radius` of a
/// placed model point before its own return; the point moves to that model point's range
/// along the beam (the nearest such point). hit_radius <= 0 takes 1.5 model spacings.
Insertion insertByRayCasting(const Cloud& scan, const Eigen::Vector3f& sensor,
                             const ObjectModel& model, const Placement& where,
                             double hit_radius = 0.0);

/// Up to `count` placements on free floor (both sweeps z-up, in one frame, each with its
/// sensor origin): the floor height is the most populated 2 cm height band 0.1 m or more
/// below the current sensor, 1-6 m out; candidates lie on a 0.2 m grid at that height (on
/// the median of the floor points under the footprint where there are any); neither sweep
/// has points below the footprint (radius + 0.1 m) or in the column above it up to the
/// object's height + 0.3 m; the object, turned with its seen side toward the
/// sensor (+-25 degrees), cuts at least `min_points` beams of the current sweep and of the
/// reference (whose beams thus saw its space free); 1-6 m from the current sensor
/// (horizontally) and at least max(0.75 m, 2 radii) apart. Candidates are visited in a seeded
/// order: the same inputs and seed give the same placements.
std::vector<Placement> freeFloorPlacements(const Cloud& current, const Eigen::Vector3f& sensor,
                                           const Cloud& reference, const ObjectModel& model,
                                           int count, std::uint64_t seed,
                                           std::size_t min_points = 40);

}  // namespace sim
}  // namespace novelty_detection
