// Private to the simulator: building corridors and offices from quads and boxes.
#pragma once

#include <Eigen/Core>

#include <vector>

#include "novelty_detection/sim/random.h"
#include "novelty_detection/sim/world.h"

namespace novelty_detection {
namespace sim {
namespace detail {

/// A rounded rectangle on the floor plan: points within `radius` of the rectangle
/// centre + R(yaw) * [-half, half].
struct Footprint {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  double yaw = 0.0;
  Eigen::Vector2d half = Eigen::Vector2d::Zero();
  double radius = 0.0;
};
/// Distance from p to the footprint's area (0 inside).
double footprintDistance(const Footprint& f, const Eigen::Vector2d& p);

/// A door leaf on a vertical hinge; angle 0 closes the opening, pi/2 lies along `into`.
struct DoorSpec {
  Eigen::Vector2d hinge = Eigen::Vector2d::Zero();
  Eigen::Vector2d along = Eigen::Vector2d::UnitX();  ///< from hinge across the opening
  Eigen::Vector2d into = Eigen::Vector2d::UnitY();   ///< the side it opens to
  double width = 0.86, height = 2.0, thickness = 0.04;
  double angle_rad = 0.0;  ///< reference opening angle
};
PrimitivePtr makeDoorLeaf(const DoorSpec& door, double angle_rad, int object_id);

/// A furniture box standing on the floor.
struct FurnitureSpec {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  double yaw = 0.0;
  Eigen::Vector3d half = Eigen::Vector3d::Constant(0.25);
};
PrimitivePtr makeFurniture(const FurnitureSpec& f, int object_id);
Footprint footprintOf(const FurnitureSpec& f);

/// What a layout builder produces. Doors and furniture are not in static_world: each sweep
/// adds them with its own angles and poses.
struct BuiltLayout {
  World static_world;
  std::vector<DoorSpec> doors;
  std::vector<FurnitureSpec> furniture;
  Eigen::Vector2d free_min = Eigen::Vector2d::Zero();  ///< interior where objects may stand
  Eigen::Vector2d free_max = Eigen::Vector2d::Zero();
  std::vector<Footprint> obstacles;  ///< pillars, furniture, space in front of doors
  std::vector<Footprint> solids;     ///< pillars and furniture only
  Eigen::Vector3d base_pose = Eigen::Vector3d::Zero();  ///< reference robot x, y, yaw
  double height = 2.7;                                  ///< floor to ceiling [m]
};

BuiltLayout buildCorridor(Rng& rng);
BuiltLayout buildOffice(Rng& rng);

}  // namespace detail
}  // namespace sim
}  // namespace novelty_detection
