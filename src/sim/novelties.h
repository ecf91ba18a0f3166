// Private to the simulator: the shapes inserted as novelties.
#pragma once

#include <vector>

#include "novelty_detection/sim/random.h"
#include "novelty_detection/sim/scene.h"

namespace novelty_detection {
namespace sim {
namespace detail {

/// An object's parts in its own frame (origin on the floor under its centre, yaw 0) and the
/// radius of a circle on the floor containing it.
struct ShapeTemplate {
  std::vector<ObjectPart> parts;
  double radius = 0.0;
};

/// Random sizes for box, cylinder, sphere, superellipsoid and person (others throw).
ShapeTemplate sampleShape(NoveltyKind kind, Rng& rng);
/// The parts moved to (x, y) on the floor and turned by yaw.
std::vector<ObjectPart> placeParts(const std::vector<ObjectPart>& parts, double x, double y,
                                   double yaw);
/// The ray-castable primitive of a part.
PrimitivePtr primitiveOf(const ObjectPart& part, int object_id);
/// A box part (near-limit superquadric e1 = e2 = 0.1).
ObjectPart boxPart(const Eigen::Vector3d& center, double yaw, const Eigen::Vector3d& half);

}  // namespace detail
}  // namespace sim
}  // namespace novelty_detection
