// Scores over several suite seeds: one seed's suite says little about the scenes a user
// will meet, so the suites are run for a list of seeds and each scene group is reported by
// its mean over the seeds and its worst seed. ROS-free.
//
// Input: the `evaluate --suite ... --json` output of each seed (its "groups": scene group,
// scenes, success_rate, mean_f1, and "summary": objects_found / objects_total, false
// segments, and optionally "shapes_by_kind"; "kinds", optional: per object type, objects and
// found). Means are over seeds (each seed
// weighs the same); the worst seed is the one with the lowest success rate in the group (ties:
// lowest F1, then the first listed).
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace novelty_detection {

struct SeedGroupSummary {
  std::string group;  ///< scene group ("same_pose", ..., "all")
  int seeds = 0;      ///< seeds that have the group
  int scenes = 0;     ///< scenes of the group over all those seeds
  double mean_success = 0.0, mean_f1 = 0.0;
  std::string worst_seed;  ///< the seed with the lowest success (then F1)
  double worst_success = 0.0, worst_f1 = 0.0;
  double min_f1 = 0.0;  ///< the lowest F1 of any seed
};

/// Changed objects of one type found over the seeds (from each file's "kinds", when present).
struct SeedKindSummary {
  std::string type;
  int objects = 0, found = 0;  ///< summed over the seeds
  std::string worst_seed;      ///< the seed with the lowest share found
  double worst_rate = 0.0;     ///< that share
};

/// Superquadric errors of one object type pooled over the seeds (from each file's
/// summary.shapes_by_kind, when present): every found object weighs the same, whatever its
/// seed.
struct SeedShapeSummary {
  std::string type;
  int objects = 0;                        ///< found objects with a shape, over the seeds
  double surface_m = 0.0, floor_m = 0.0;  ///< mean surface error, mean floor
  int axis_objects = 0;                   ///< one-part objects fitted with one part
  double semi_axis_m = 0.0;               ///< their mean semi-axis error
  int seen_axis_objects = 0;              ///< of them, those seen with kWellSeenPoints or more
  double seen_semi_axis_m = 0.0;          ///< their mean semi-axis error
  int seen_objects = 0, seen_parts_3_to_7 = 0;  ///< objects so seen; of them with 3 to 7 parts
};

struct SeedSummary {
  std::vector<std::string> seeds;        ///< as given
  std::vector<SeedGroupSummary> groups;  ///< in first-seen order, "all" last
  std::vector<SeedKindSummary> kinds;    ///< in first-seen order
  std::vector<SeedShapeSummary> shapes;  ///< in first-seen order
  long objects_found = 0, objects_total = 0, false_segments = 0;  ///< summed over seeds
};

/// Reads each (seed, scores JSON path); throws std::runtime_error naming the file for a
/// missing or malformed one, std::invalid_argument for no seeds or a repeated seed.
SeedSummary summarizeSeeds(const std::vector<std::pair<std::string, std::string>>& seed_scores);

/// A Markdown table: group, seeds, scenes, mean success, worst seed (its success and F1),
/// mean F1, lowest F1; then one line of objects found and false segments; then, when the
/// files give them, objects found per type (all seeds, and the worst seed) and the shapes
/// per type pooled over the seeds.
std::string seedSummaryMarkdown(const SeedSummary& summary);
/// The same as one JSON object.
std::string seedSummaryJson(const SeedSummary& summary);

}  // namespace novelty_detection
