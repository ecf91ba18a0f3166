// The points of a simulated scene's changed objects, as the shape tests fit them. Test-only.
#pragma once

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>

#include "novelty_detection/pipeline.h"
#include "novelty_detection/preprocess/multiscale_tree.h"
#include "novelty_detection/preprocess/range_noise.h"
#include "novelty_detection/shape/fit_bounds.h"
#include "novelty_detection/shape/superquadric_fit.h"
#include "novelty_detection/sim/scene.h"
#include "novelty_detection/visibility/visibility.h"

namespace novelty_detection {
namespace sim_objects {

/// The detector's result on a simulated pair with `params`, superquadrics off (the tests
/// that call it measure labels).
inline Result detectLabels(const sim::ScenePair& scene, Params params = Params()) {
  params.superquadric.enabled = false;
  Pipeline pipeline(params);
  pipeline.setReference(scene.reference);
  return pipeline.detect(scene.current);
}

/// The best IoU of any segment of `labels` (one per point of scene.current, 0: none) with
/// changed object `id`; `points`, when given, gets the object's point count.
inline double bestSegmentIou(const sim::ScenePair& scene, const std::vector<int>& labels, int id,
                             long* points = nullptr) {
  std::map<int, long> common, size;
  long object = 0;
  for (std::size_t i = 0; i < labels.size(); ++i) {
    object += scene.current_labels[i] == id;
    if (labels[i] > 0) {
      ++size[labels[i]];
      common[labels[i]] += scene.current_labels[i] == id;
    }
  }
  if (points) *points = object;
  double best = 0.0;
  for (const auto& [label, n] : size)
    best = std::max(best, static_cast<double>(common[label]) / (object + n - common[label]));
  return best;
}

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

/// What bounds a changed object's fit in the detector, from the scene's true labels: the
/// sweep seen from its origin, the floor z = 0 with a band and a free-space margin of three
/// times the range noise (about the detector's tau), the simulator's constant range noise.
/// Not movable: `source` and `bounds` point into it.
struct ObjectBounds {
  RangeImage view;
  RangeNoise noise;
  FitBoundsSource source;
  FitBounds bounds;
};

/// The sweep's noise model as the detector estimates it (from the multi-scale tree of the
/// whole current sweep): normal to surfaces, below the simulator's range sigma.
inline RangeNoise sweepNoise(const sim::ScenePair& scene) {
  MultiScaleTree tree;
  tree.build(scene.current);
  const Eigen::Vector3f origin = scene.current.sensor_origin_.head<3>();
  return estimateRangeNoise(tree, &origin);
}

/// Bounds of object `id` as the detector builds them; `noise` (optional) replaces the noise
/// model, the simulator's range sigma by default.
inline std::unique_ptr<ObjectBounds> boundsOf(const sim::ScenePair& scene,
                                              const sim::SceneConfig& cfg, int id,
                                              const Points3d& fine,
                                              const SuperquadricParams& params,
                                              const RangeNoise* noise = nullptr) {
  auto b = std::make_unique<ObjectBounds>();
  const double sigma = std::sqrt(cfg.laser.noise_variance_m2);
  b->view.build(scene.current, {}, scene.current.sensor_origin_.head<3>(),
                rangeImageConfig(VisibilityParams()));
  b->noise.estimated = true;
  b->noise.scale = sigma;
  if (noise) b->noise = *noise;
  b->source.sweep = &scene.current;
  b->source.labels = &scene.current_labels;
  b->source.view = &b->view;
  b->source.margin_m = 3.0 * sigma;
  b->source.has_floor = true;
  b->source.floor = Eigen::Vector4d(0, 0, 1, 0);
  b->source.floor_band_m = 3.0 * sigma;
  b->source.noise = &b->noise;
  b->bounds = fitBoundsFor(fine, id, b->source, params);
  return b;
}

}  // namespace sim_objects
}  // namespace novelty_detection
