// Scoring detection against patrol routes (sim/route.h): a reference of many sweeps, a
// sequence of current sweeps, changes tracked over the sequence. ROS-free.
//
// For each route scene three references are compared on the same current sweeps:
// - "route": the merged route map with every sweep's viewpoint (what a patrol robot builds);
// - "single": the one route sweep whose sensor stood nearest the first current sweep's;
// - "baseline": voxel differencing (eval/baseline.h) against the merged route map, its voxel
//   edge from the sampling of the single sweep above (resolution_factor x its median spacing).
// Each current sweep is scored with scoreLabels (evaluation.h) against its ground truth: the
// staying object and the person are both changes of that sweep. An object with fewer than
// kMinScoredPoints points in a sweep (a person at the edge of the view) is left out of that
// sweep's score (its points count neither way). The route method's results also go through a
// ChangeTracker (tracking/change_tracker.h): the scene's object is confirmed when, on the last
// sweep, a confirmed track holds a segment most of whose points lie on the staying object; the
// person is rejected when no confirmed track ever holds a segment most of whose points lie on
// the person.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "novelty_detection/eval/baseline.h"
#include "novelty_detection/eval/evaluation.h"
#include "novelty_detection/params.h"
#include "novelty_detection/sim/route.h"

namespace novelty_detection {

struct RouteMethodScores {
  std::vector<SceneScore> sweeps;  ///< one per current sweep
  std::vector<double> detect_ms;   ///< wall time per current sweep
  double reference_ms = 0.0;       ///< building the reference model (or 0 for the baseline)
  int not_compared = 0;  ///< sweeps refused as not overlapping the reference (found nothing)
};

struct RouteSceneResult {
  int index = 0;
  std::uint64_t seed = 0;
  std::string layout;
  int reference_sweeps = 0;
  std::size_t reference_points = 0, current_points = 0;  ///< the map; the first current sweep
  RouteMethodScores route, single, baseline;
  bool object_confirmed = false;
  bool person_detected = false;  ///< some sweep has a segment mostly on the person
  bool person_rejected = false;
  int confirmed_on_sweep = -1;  ///< first sweep whose object segment's track is confirmed
};

struct RouteSummary {
  int scenes = 0, sweeps = 0;
  double success_rate = 0.0, mean_f1 = 0.0;  ///< route map, over every current sweep
  double confirmed_rate = 0.0, transient_rejected_rate = 0.0, person_detected_rate = 0.0;
  double single_success_rate = 0.0, single_mean_f1 = 0.0;
  double baseline_success_rate = 0.0, baseline_mean_f1 = 0.0;
  double median_reference_s = 0.0, max_reference_s = 0.0;  ///< route map model
  double median_detect_s = 0.0, max_detect_s = 0.0;        ///< against the route map
  double median_single_detect_s = 0.0;                     ///< against one sweep
};

constexpr int kMinScoredPoints = 50;

/// Runs the three methods on one scene. `with_comparisons` false runs the route map only.
RouteSceneResult evaluateRouteScene(const sim::RouteScene& scene, int index, const Params& params,
                                    const BaselineOptions& baseline, bool with_comparisons = true);

RouteSummary summarizeRoutes(const std::vector<RouteSceneResult>& results);

/// The summary as one JSON object (one line; `skipped_scenes`: scenes the simulator could not
/// lay out, left out of every figure), and a Markdown table per scene plus totals.
std::string routeSummaryJson(const RouteSummary& summary, int skipped_scenes = 0);
std::string routeMarkdown(const std::vector<RouteSceneResult>& results, const RouteSummary& s);

}  // namespace novelty_detection
