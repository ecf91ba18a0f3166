// The points of a simulated scene's changed objects, as the shape tests fit them. Test-only.
#pragma once

#include "novelty_detection/shape/superquadric_fit.h"
#include "novelty_detection/sim/scene.h"

namespace novelty_detection {
namespace sim_objects {

/// The current sweep's points on changed object `id` (its ground-truth label).
inline Points3d objectPoints(const sim::ScenePair& scene, int id) {
  Points3d out;
  for (std::size_t i = 0; i < scene.current.size(); ++i)
    if (scene.current_labels[i] == id)
      out.emplace_back(scene.current[i].x, scene.current[i].y, scene.current[i].z);
  return out;
}

/// A stand-in for the multi-scale cut's representatives inside a segment: an eighth of its
/// points (at least 11).
inline Points3d coarsePoints(const Points3d& fine) {
  return subsample(fine, static_cast<int>(fine.size() / 8) + 11);
}

}  // namespace sim_objects
}  // namespace novelty_detection
