// Scoring the superquadrics of detected novelties against ground truth. ROS-free.
//
// For every ground-truth object that was found (a predicted segment overlaps it with IoU
// >= the match threshold, see evaluation.h), the shape error is the mean, over the
// object's TRUE points, of the distance to the nearest superquadric of the matching
// segment (first-order surface distance, superquadric.h). It measures how well the fitted
// shapes describe the real object, including the points the segmentation missed.
#pragma once

#include <string>
#include <vector>

#include "novelty_detection/eval/evaluation.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

struct ShapeScore {
  int objects = 0;                       ///< found objects whose segment has superquadrics
  double mean_surface_distance_m = 0.0;  ///< mean over those objects
  std::vector<std::pair<int, double>> per_object;  ///< (object id, mean distance [m])
};

/// Reads superquadrics.json as novelty_detect writes it (the output contract: segment, a,
/// epsilon, position, orientation.euler ZYZ). Throws std::runtime_error naming the file.
std::vector<Superquadric> readSuperquadricsJson(const std::string& path);

/// `cloud` is the current cloud, `truth` its ground-truth labels, `score` the label score
/// of the scene (its objects' best segments), `superquadrics` the fitted parts.
ShapeScore scoreShapes(const Cloud& cloud, const std::vector<int>& truth, const SceneScore& score,
                       const std::vector<Superquadric>& superquadrics);

}  // namespace novelty_detection
