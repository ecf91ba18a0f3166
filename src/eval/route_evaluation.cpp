#include "novelty_detection/eval/route_evaluation.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <iomanip>
#include <map>
#include <sstream>

#include "novelty_detection/pipeline.h"
#include "novelty_detection/preprocess/input_check.h"
#include "novelty_detection/tracking/change_tracker.h"

namespace novelty_detection {

namespace {

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

/// Truth and prediction with the objects too small to score in this sweep left out.
SceneScore scoreSweep(std::vector<int> predicted, std::vector<int> truth) {
  std::map<int, int> counts;
  for (int l : truth)
    if (l > 0) ++counts[l];
  for (std::size_t i = 0; i < truth.size(); ++i) {
    if (truth[i] > 0 && counts[truth[i]] < kMinScoredPoints) predicted[i] = truth[i] = 0;
  }
  return scoreLabels(predicted, truth);
}

/// The ground-truth label most of a segment's points carry (0: static scene).
int majorityLabel(const Segment& seg, const std::vector<int>& truth) {
  std::map<int, std::size_t> votes;
  for (int i : seg.indices) ++votes[truth[i]];
  int best = 0;
  std::size_t most = 0;
  for (const auto& [label, n] : votes)
    if (n > most) {
      most = n;
      best = label;
    }
  return 2 * most > seg.indices.size() ? best : 0;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

void runPipeline(const Params& params, const Cloud& map, const ReferenceViews& views,
                 const sim::RouteScene& scene, RouteMethodScores* out,
                 std::vector<Result>* results) {
  Pipeline pipeline(params);
  const auto t0 = Clock::now();
  pipeline.setReference(map, views);
  out->reference_ms = msSince(t0);
  for (const sim::RouteSweep& sweep : scene.sequence) {
    const auto t1 = Clock::now();
    Result r;
    try {
      r = pipeline.detect(sweep.cloud);
    } catch (const NoOverlapError&) {
      // Not compared: scored as finding nothing (a failed sweep when it holds a change).
      r = Result();
      r.labels.assign(sweep.cloud.size(), 0);
      ++out->not_compared;
    }
    out->detect_ms.push_back(msSince(t1));
    out->sweeps.push_back(scoreSweep(r.labels, sweep.labels));
    if (results) results->push_back(std::move(r));
  }
}

double rate(int n, int d) { return d > 0 ? static_cast<double>(n) / d : 0.0; }

}  // namespace

RouteSceneResult evaluateRouteScene(const sim::RouteScene& scene, int index, const Params& params,
                                    const BaselineOptions& baseline, bool with_comparisons) {
  RouteSceneResult r;
  r.index = index;
  r.seed = scene.config.seed;
  r.layout = sim::toString(scene.config.layout);
  r.reference_sweeps = static_cast<int>(scene.reference.size());
  r.current_points = scene.sequence.empty() ? 0 : scene.sequence.front().cloud.size();
  ReferenceViews views;
  const Cloud map = sim::mergedReference(scene, &views);
  r.reference_points = map.size();

  std::vector<Result> results;
  runPipeline(params, map, views, scene, &r.route, &results);
  // Changes over time on the route map's results.
  ChangeTracker tracker(params.tracking);
  r.person_rejected = true;
  for (std::size_t k = 0; k < results.size(); ++k) {
    const sim::RouteSweep& sweep = scene.sequence[k];
    const auto ids =
        tracker.update(results[k].segments, static_cast<double>(k), usableExtent(sweep.cloud));
    for (std::size_t s = 0; s < ids.size(); ++s) {
      const ChangeTrack* t = tracker.track(ids[s]);
      const bool confirmed = t && t->confirmed;
      const int label = majorityLabel(results[k].segments[s], sweep.labels);
      if (label == sim::kWalkingPersonId) {
        r.person_detected = true;
        if (confirmed) r.person_rejected = false;
      }
      if (label == sim::kStayingObjectId && confirmed) {
        if (r.confirmed_on_sweep < 0) r.confirmed_on_sweep = static_cast<int>(k);
        if (k + 1 == results.size()) r.object_confirmed = true;
      }
    }
  }

  if (with_comparisons) {
    ReferenceViews none;
    const Cloud one = sim::mergedReference(scene, nullptr, scene.nearest_reference);
    runPipeline(params, one, none, scene, &r.single, nullptr);
    // The voxel edge from one sweep's sampling (the merged map is denser than any sweep: its
    // own spacing would give voxels smaller than the sweeps' gaps).
    BaselineOptions voxels = baseline;
    if (voxels.resolution_m <= 0.0)
      voxels.resolution_m = voxels.resolution_factor * medianPointSpacing(one);
    for (const sim::RouteSweep& sweep : scene.sequence) {
      const auto t0 = Clock::now();
      // Appearances only: what the map holds and one sweep does not see is most of the map.
      const std::vector<int> labels = voxelChangeLabels(
          map, sweep.cloud, voxels.resolution_m,
          voxels.cluster_tolerance_factor * voxels.resolution_m, voxels.min_cluster_size);
      r.baseline.detect_ms.push_back(msSince(t0));
      r.baseline.sweeps.push_back(scoreSweep(labels, sweep.labels));
    }
  }
  return r;
}

RouteSummary summarizeRoutes(const std::vector<RouteSceneResult>& results) {
  RouteSummary s;
  s.scenes = static_cast<int>(results.size());
  int ok = 0, single_ok = 0, single_n = 0, base_ok = 0, base_n = 0, confirmed = 0, rejected = 0,
      detected = 0;
  double f1 = 0, single_f1 = 0, base_f1 = 0;
  std::vector<double> ref_s, det_s, single_det_s;
  for (const RouteSceneResult& r : results) {
    for (const SceneScore& sc : r.route.sweeps) {
      ++s.sweeps;
      ok += sc.success;
      f1 += sc.f1;
    }
    for (const SceneScore& sc : r.single.sweeps) {
      ++single_n;
      single_ok += sc.success;
      single_f1 += sc.f1;
    }
    for (const SceneScore& sc : r.baseline.sweeps) {
      ++base_n;
      base_ok += sc.success;
      base_f1 += sc.f1;
    }
    confirmed += r.object_confirmed;
    rejected += r.person_rejected;
    detected += r.person_detected;
    ref_s.push_back(r.route.reference_ms / 1000.0);
    for (double ms : r.route.detect_ms) det_s.push_back(ms / 1000.0);
    for (double ms : r.single.detect_ms) single_det_s.push_back(ms / 1000.0);
  }
  s.success_rate = rate(ok, s.sweeps);
  s.mean_f1 = s.sweeps ? f1 / s.sweeps : 0.0;
  s.confirmed_rate = rate(confirmed, s.scenes);
  s.transient_rejected_rate = rate(rejected, s.scenes);
  s.person_detected_rate = rate(detected, s.scenes);
  s.single_success_rate = rate(single_ok, single_n);
  s.single_mean_f1 = single_n ? single_f1 / single_n : 0.0;
  s.baseline_success_rate = rate(base_ok, base_n);
  s.baseline_mean_f1 = base_n ? base_f1 / base_n : 0.0;
  s.median_reference_s = median(ref_s);
  s.max_reference_s = ref_s.empty() ? 0.0 : *std::max_element(ref_s.begin(), ref_s.end());
  s.median_detect_s = median(det_s);
  s.max_detect_s = det_s.empty() ? 0.0 : *std::max_element(det_s.begin(), det_s.end());
  s.median_single_detect_s = median(single_det_s);
  return s;
}

std::string routeSummaryJson(const RouteSummary& s, int skipped_scenes) {
  nlohmann::json j;
  j["scenes"] = s.scenes;
  j["skipped_scenes"] = skipped_scenes;
  j["sweeps"] = s.sweeps;
  j["success_rate"] = s.success_rate;
  j["mean_f1"] = s.mean_f1;
  j["confirmed_rate"] = s.confirmed_rate;
  j["transient_rejected_rate"] = s.transient_rejected_rate;
  j["person_detected_rate"] = s.person_detected_rate;
  j["single_sweep"] = {{"success_rate", s.single_success_rate}, {"mean_f1", s.single_mean_f1}};
  j["voxel_baseline"] = {{"success_rate", s.baseline_success_rate},
                         {"mean_f1", s.baseline_mean_f1}};
  j["median_reference_s"] = s.median_reference_s;
  j["max_reference_s"] = s.max_reference_s;
  j["median_detect_s"] = s.median_detect_s;
  j["max_detect_s"] = s.max_detect_s;
  j["median_single_detect_s"] = s.median_single_detect_s;
  return j.dump();
}

std::string routeMarkdown(const std::vector<RouteSceneResult>& results, const RouteSummary& s) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(3);
  out << "| scene | layout | map sweeps | map points | route: success | route: F1 | single: F1 "
         "| voxel: F1 | object confirmed | person rejected |\n"
      << "|---|---|---|---|---|---|---|---|---|---|\n";
  for (const RouteSceneResult& r : results) {
    int ok = 0;
    double f1 = 0, sf1 = 0, bf1 = 0;
    for (const auto& sc : r.route.sweeps) ok += sc.success, f1 += sc.f1;
    for (const auto& sc : r.single.sweeps) sf1 += sc.f1;
    for (const auto& sc : r.baseline.sweeps) bf1 += sc.f1;
    const double n = std::max<std::size_t>(1, r.route.sweeps.size());
    out << "| " << r.index << " | " << r.layout << " | " << r.reference_sweeps << " | "
        << r.reference_points << " | " << ok << "/" << r.route.sweeps.size() << " | " << f1 / n
        << " | " << (r.single.sweeps.empty() ? 0.0 : sf1 / r.single.sweeps.size()) << " | "
        << (r.baseline.sweeps.empty() ? 0.0 : bf1 / r.baseline.sweeps.size()) << " | "
        << (r.object_confirmed ? "yes" : "no") << " | " << (r.person_rejected ? "yes" : "no")
        << " |\n";
  }
  out << "\n| reference | sweeps scored | success | mean F1 |\n|---|---|---|---|\n"
      << "| route map (all sweeps, their viewpoints) | " << s.sweeps << " | "
      << 100.0 * s.success_rate << " % | " << s.mean_f1 << " |\n"
      << "| single sweep (the nearest) | " << s.sweeps << " | " << 100.0 * s.single_success_rate
      << " % | " << s.single_mean_f1 << " |\n"
      << "| voxel difference against the route map | " << s.sweeps << " | "
      << 100.0 * s.baseline_success_rate << " % | " << s.baseline_mean_f1 << " |\n"
      << "\nObject confirmed " << 100.0 * s.confirmed_rate << " %, person never confirmed "
      << 100.0 * s.transient_rejected_rate << " % (detected in some sweep "
      << 100.0 * s.person_detected_rate << " %); route map model " << s.median_reference_s
      << " s median (worst " << s.max_reference_s << " s), detection " << s.median_detect_s
      << " s median (worst " << s.max_detect_s << " s), against one sweep "
      << s.median_single_detect_s << " s.\n";
  return out.str();
}

}  // namespace novelty_detection
