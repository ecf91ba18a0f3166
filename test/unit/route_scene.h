// A two-sweep route in a corridor with a pillar, for the tests of references made of
// several sweeps (known answers: which space each sweep saw).
//
// The corridor x in [-3, 12] has a full-height pillar at x in [3, 3.4]. Sweep A is taken
// from (0, 0, 0.6) looking along +x, so the space behind the pillar is in its shadow; sweep
// B from (8, 0, 0.6) looking along -x sees that space up to the pillar. The new object
// stands in A's shadow, in space B saw as free; the current sweep is taken from C.
#pragma once

#include <vector>

#include "synthetic_scene.h"

namespace novelty_detection {
namespace route_scene {

using synthetic::AlignedBox;

inline const AlignedBox kPillar{{3.0, -0.4, 0.0}, {3.4, 0.4, 2.6}};
inline const AlignedBox kObject{{4.4, -0.2, 0.0}, {4.8, 0.2, 0.8}};
inline const Eigen::Vector3d kA(0.0, 0.0, 0.6), kB(8.0, 0.0, 0.6), kC(6.5, 0.5, 0.6);

/// A tilting-laser sweep of the corridor from `sensor`, looking along +x, or along -x with
/// `backwards` (the sweep is simulated in the mirrored corridor and mirrored back).
inline synthetic::Scene sweepFrom(Eigen::Vector3d sensor, std::vector<AlignedBox> objects,
                                  bool backwards, unsigned seed) {
  synthetic::SceneOptions o;
  o.seed = seed;
  o.range_sigma_m = 0.01;
  auto mirror = [](const AlignedBox& b) {
    return AlignedBox{{-b.hi.x(), b.lo.y(), b.lo.z()}, {-b.lo.x(), b.hi.y(), b.hi.z()}};
  };
  if (backwards) {
    o.room = mirror(o.room);
    for (AlignedBox& b : objects) b = mirror(b);
    sensor.x() = -sensor.x();
  }
  o.sensor = sensor;
  o.objects = objects;
  synthetic::Scene s = synthetic::makeCorridor(o);
  if (backwards)
    for (PointT& p : s.cloud) p.x = -p.x;
  return s;
}

}  // namespace route_scene
}  // namespace novelty_detection
