// Scoring the superquadrics of detected novelties against ground truth. ROS-free.
//
// For every ground-truth object that was found (a predicted segment overlaps it with IoU
// >= the match threshold, see evaluation.h), the shape error is the mean, over the
// object's TRUE points, of the distance to the nearest superquadric of the matching
// segment (first-order surface distance, superquadric.h). It measures how well the fitted
// shapes describe the real object, including the points the segmentation missed.
#pragma once

#include <limits>
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

/// A changed object's true shape (scene.json "objects": id, type, parts).
struct TrueShape {
  int id = 0;
  std::string type;                 ///< "box", "cylinder", "sphere", "door", "person", ...
  std::vector<Superquadric> parts;  ///< one per part of the simulated object
};

/// Objects the sweep saw with at least this many points are reported apart too ("well
/// seen"): with fewer the sweep holds a few scan lines of the object or a corner left visible
/// by what stands in front of it, and its unseen extent (the depth of a box seen on one face,
/// the width of a cylinder seen as a strip, a person's legs, trunk and head on separate lines)
/// is not in the data.
constexpr std::size_t kWellSeenPoints = 150;

/// How well one found object's superquadrics describe it, beside what its data allow.
struct ObjectShapeError {
  int id = 0;
  std::string type;
  std::size_t points = 0;  ///< its true points in the sweep
  double fit_m = 0.0;      ///< mean over its true points of the distance to its segment's parts
  double floor_m = 0.0;    ///< the same to its true parts: the sensor noise, the best a fit can do
  /// Single-part objects fitted with one part: mean over the three axes of |a_fit - a_true|,
  /// both sorted by size (a one-sided view that gets the hidden extent wrong shows here);
  /// NaN otherwise.
  double semi_axis_error_m = std::numeric_limits<double>::quiet_NaN();
  int parts = 0;  ///< superquadrics fitted to its segment
  /// Angle between up (+z, the simulator's) and the long axis of the fitted part that stands
  /// for its main body [deg, 0..90]: of its points nearest its largest true part (by volume:
  /// a person's torso), the fitted part nearest most of them.
  double main_part_tilt_deg = std::numeric_limits<double>::quiet_NaN();
};

/// Per object kind: means over its found objects (semi-axis error over those that have one).
struct KindShapeError {
  std::string type;
  int objects = 0;
  double fit_m = 0.0, floor_m = 0.0;
  int axis_objects = 0;
  double semi_axis_error_m = 0.0;
  double parts_mean = 0.0;  ///< fitted parts per object
  int parts_3_to_7 = 0;     ///< objects fitted with 3 to 7 parts (a person's range)
  int main_part_within_20 =
      0;  ///< objects whose main body's part (main_part_tilt_deg) is within 20 deg of up
  /// The same counts and the semi-axis error over the objects seen with at least
  /// kWellSeenPoints points.
  int seen_objects = 0, seen_axis_objects = 0, seen_parts_3_to_7 = 0;
  double seen_semi_axis_error_m = 0.0;
  double ratio() const { return floor_m > 0.0 ? fit_m / floor_m : 0.0; }
};

/// Reads the changed objects' true shapes from a scene's scene.json. Throws
/// std::runtime_error naming the file and what is wrong.
std::vector<TrueShape> readTrueShapes(const std::string& scene_json);

/// The fitted part that stands for an object's main body: of its `points` nearest its
/// largest true part (by volume: a person's torso), the fitted part nearest most of them
/// (surface distance); the largest fitted part when none is; null when `fitted` is empty.
const Superquadric* mainFittedPart(const Points3d& points,
                                   const std::vector<const Superquadric*>& true_parts,
                                   const std::vector<const Superquadric*>& fitted);

/// For every found object with superquadrics and a true shape: its errors (above).
std::vector<ObjectShapeError> scoreShapesByObject(const Cloud& cloud, const std::vector<int>& truth,
                                                  const SceneScore& score,
                                                  const std::vector<Superquadric>& superquadrics,
                                                  const std::vector<TrueShape>& shapes);

/// Means per kind, sorted by kind.
std::vector<KindShapeError> summarizeShapesByKind(const std::vector<ObjectShapeError>& objects);

/// Reads superquadrics.json as novelty_detect writes it (the output contract: segment, a,
/// epsilon, position, orientation.euler ZYZ). Throws std::runtime_error naming the file.
std::vector<Superquadric> readSuperquadricsJson(const std::string& path);

/// `cloud` is the current cloud, `truth` its ground-truth labels, `score` the label score
/// of the scene (its objects' best segments), `superquadrics` the fitted parts.
ShapeScore scoreShapes(const Cloud& cloud, const std::vector<int>& truth, const SceneScore& score,
                       const std::vector<Superquadric>& superquadrics);

}  // namespace novelty_detection
