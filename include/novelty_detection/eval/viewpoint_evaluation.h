// Scoring per scene group for viewpoint robustness: appearances as in
// evaluation.h, disappearances on the reference points, and newly visible surfaces wrongly
// labelled novel. ROS-free.
//
// Files of a simulated scene (simulate_scans): gt_labels.txt (per current point),
// gt_disappeared_labels.txt (per reference point: 0, or k > 0 when it lies on the reference
// pose of changed object k), gt_newly_visible.txt (per current point, 0/1) and scene.json
// ("group", "removed_objects"). Files of a result: labels.txt, disappeared_labels.txt (per
// reference point, 0 or a disappearance segment id), newly_visible.txt (per current point,
// 0/1; optional, only counted).
//
// Rules (mirroring evaluation.h's object rule):
// - A removed object is found when one disappearance segment has IoU >= match_iou with the
//   reference points on it (scoreLabels on the reference points). A removal scene's
//   disappearances are found when all its removed objects are. Without a readable
//   disappeared_labels.txt they count as not found.
// - Mean point F1 of a group is over its scenes with at least one appearance (current points
//   labelled > 0 in the ground truth); scene success (evaluation.h) is over all its scenes.
// - Newly visible: ground-truth newly visible current points whose predicted label is > 0,
//   summed over the group's scenes and divided by the group's newly visible points.
#pragma once

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "novelty_detection/eval/evaluation.h"

namespace novelty_detection {

struct ViewpointSceneScore {
  std::string name;
  std::string group = "unknown";  ///< scene.json "group"
  bool has_result = false;        ///< labels.txt was scored
  bool has_appearances = false;   ///< the ground truth has novel current points
  SceneScore appearance;          ///< labels.txt vs gt_labels.txt

  /// scene.json "objects": (id, "type") of each changed object ("box", "door", "person"...).
  std::vector<std::pair<int, std::string>> object_types;

  std::vector<int> removed_ids;  ///< scene.json "removed_objects"
  int removed_found = 0;         ///< of removed_ids
  bool has_disappeared = false;  ///< disappeared_labels.txt was scored
  std::string disappeared_note;  ///< why not, e.g. "missing disappeared_labels.txt"
  SceneScore disappearance;      ///< on reference points (all changed objects' old poses)

  bool has_newly_visible_truth = false;
  std::size_t newly_visible_points = 0;    ///< ground truth
  std::size_t newly_visible_novel = 0;     ///< of them, labelled > 0 in labels.txt
  bool has_newly_visible_result = false;   ///< newly_visible.txt was read
  std::size_t newly_visible_reported = 0;  ///< of them, marked 1 in newly_visible.txt
};

struct GroupSummary {
  std::string group;
  int scenes = 0, successes = 0;
  int appearance_scenes = 0;
  double mean_f1 = 0.0;  ///< over appearance scenes
  int removal_scenes = 0, removal_scenes_found = 0;
  int removed_objects = 0, removed_found = 0;
  int removal_scenes_without_result = 0;  ///< no readable disappeared_labels.txt
  std::size_t newly_visible_points = 0, newly_visible_novel = 0;
  double newly_visible_novel_fraction = 0.0;
};

/// Scores the viewpoint part of one scene from its directories; `appearance` and
/// `has_result` come from the usual scoring of labels.txt. Missing ground-truth files leave
/// their part empty (an old suite); a missing or unreadable disappeared_labels.txt leaves
/// the removed objects not found and sets disappeared_note. Throws std::runtime_error for
/// unreadable ground truth.
ViewpointSceneScore scoreViewpointScene(const std::string& name, const std::string& scene_dir,
                                        const std::string& result_dir, const SceneScore& appearance,
                                        bool has_result, const EvaluationOptions& options = {});

/// One summary per group, in the order same_pose, pose_offset, localisation_error, then any
/// other group by name, then "all" (every scene).
std::vector<GroupSummary> summarizeGroups(const std::vector<ViewpointSceneScore>& scenes);

/// Markdown table: one row per group.
std::string groupsMarkdown(const std::vector<GroupSummary>& groups);

/// Appearances found per object type: an object counts when it has current points and a
/// segment with IoU >= match_iou (SceneScore::objects); a scene of the type when every
/// object of that type in it was found.
struct KindSummary {
  std::string type;
  int objects = 0, found = 0;
  int scenes = 0, scenes_found = 0;
};
/// One summary per type, by name; scenes without a scored result count as not found.
std::vector<KindSummary> summarizeKinds(const std::vector<ViewpointSceneScore>& scenes);
/// Markdown table: one row per type.
std::string kindsMarkdown(const std::vector<KindSummary>& kinds);

}  // namespace novelty_detection
