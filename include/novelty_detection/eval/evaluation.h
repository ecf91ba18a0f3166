// Scoring novelty labels against ground truth (per point, per object, per scene, per suite).
// ROS-free.
//
// Labels are one integer per point of the current cloud: 0 = not novel, k > 0 = the id of a
// predicted segment (prediction) or of a changed object (ground truth).
//
// Definitions (docs/evaluation.md, "Scoring"):
// - Point level, on the novelty masks (label > 0): TP, FP, FN, TN; precision = TP/(TP+FP),
//   recall = TP/(TP+FN), F1 = 2PR/(P+R), IoU = TP/(TP+FP+FN). When a denominator is zero the
//   score is 1 if both masks are empty (nothing to find, nothing claimed) and 0 otherwise.
// - Object level: IoU between a predicted segment and a ground-truth object is computed on
//   their point sets. An object is found when one segment has IoU >= match_iou (0.5) with it
//   (at most one segment can: each such segment holds more than half of the object).
// - A segment matched to no object is a fragment when more than half of its points lie on
//   changed objects (a piece of a real change), else a false segment.
// - Scene success: every object found and no false segment larger than
//   false_segment_fraction (1 %) of the scan's points. No objects and no segments: success.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace novelty_detection {

struct EvaluationOptions {
  double match_iou = 0.5;                ///< segment-object IoU for a detection
  double false_segment_fraction = 0.01;  ///< larger false segments fail the scene
};

struct ObjectScore {
  int id = 0;
  std::size_t points = 0;
  int best_segment = 0;  ///< segment with the highest IoU (0: none overlaps)
  double best_iou = 0.0;
  bool found = false;
};

struct SegmentScore {
  int id = 0;
  std::size_t points = 0;
  std::size_t novel_points = 0;  ///< of its points, those on changed objects
  int matched_object = 0;        ///< object with IoU >= match_iou, 0 if none
  double best_iou = 0.0;
  bool false_segment = false;
};

struct SceneScore {
  std::size_t points = 0;
  std::size_t tp = 0, fp = 0, fn = 0, tn = 0;
  double precision = 0.0, recall = 0.0, f1 = 0.0, iou = 0.0;
  std::vector<ObjectScore> objects;    ///< ascending id
  std::vector<SegmentScore> segments;  ///< ascending id
  int objects_found = 0;
  int false_segments = 0;
  int fragment_segments = 0;
  std::size_t largest_false_segment = 0;  ///< points
  bool success = false;
};

/// Scores one scene. Throws std::invalid_argument when the sizes differ or a label is
/// negative, or for options outside (0, 1].
SceneScore scoreLabels(const std::vector<int>& predicted, const std::vector<int>& truth,
                       const EvaluationOptions& options = {});

/// Reads whitespace-separated integer labels. Throws std::runtime_error naming the file and
/// line for a missing file, a token that is not an integer, or a negative label; when
/// expected_count >= 0, also for a different number of labels.
std::vector<int> readLabelFile(const std::string& path, long expected_count = -1);
/// Writes one label per line (atomically: temporary file, then rename).
void writeLabelFile(const std::string& path, const std::vector<int>& labels);

/// One scene of a suite; a scene without a usable result counts as failed with zero scores.
struct SuiteEntry {
  std::string name;
  bool has_result = false;
  std::string note;  ///< why there is no result, e.g. "missing labels.txt"
  SceneScore score;
};

struct SuiteSummary {
  int scenes = 0, successes = 0, missing = 0;
  double success_rate = 0.0;
  double mean_precision = 0.0, mean_recall = 0.0, mean_f1 = 0.0, mean_iou = 0.0;
  int objects_found = 0, objects_total = 0;
  int false_segments = 0;
};

/// Means over all scenes, scenes without a result contributing zeros.
SuiteSummary summarizeSuite(const std::vector<SuiteEntry>& entries);
/// Per-scene table plus a summary, as Markdown or CSV.
std::string suiteMarkdown(const std::vector<SuiteEntry>& entries, const SuiteSummary& summary);
std::string suiteCsv(const std::vector<SuiteEntry>& entries);

}  // namespace novelty_detection
