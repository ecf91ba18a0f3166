// Cost of the viewpoint stages (visibility rule, hidden segments, newly visible, disappearances) on
// a simulated ~30k-point sweep, each with the accuracy it reached as counters:
//   RangeImageBuild   the reference's spherical range image (built once per reference)
//   NewlyVisible      classifying every current point (precision/recall against ray casting)
//   Disappearances    the current range image + the see-through test + segments (F1 of the
//                     removed box's reference points)
//   Detect/0|1        the whole detection without / with the visibility stages (superquadrics
//                     off), with the per-stage times of the extra stages as counters
//
//   bench_visibility --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <map>
#include <string>

#include "novelty_detection/pipeline.h"
#include "novelty_detection/segmentation/novelty_segmentation.h"
#include "novelty_detection/sim/scene.h"
#include "novelty_detection/visibility/disappearance.h"
#include "novelty_detection/visibility/visibility.h"

using namespace novelty_detection;

namespace {

// A removed box seen from a shifted pose: the reference is the scene's current sweep (box
// present), the current is its reference sweep (box gone).
struct Removal {
  sim::ScenePair s;
  Cloud reference, current;
  std::vector<int> box;     // per reference point
  std::vector<int> hidden;  // per current point: the reference's ray to it hits the box
};

const Removal& removal() {
  static const Removal r = [] {
    sim::SceneConfig c;
    c.seed = 3;
    c.novelty_kinds = {sim::NoveltyKind::kBox};
    Removal out;
    out.s = sim::generateScenePair(c);
    out.reference = out.s.current;
    out.current = out.s.reference;
    out.box = out.s.current_labels;
    const Eigen::Vector3d o = out.reference.sensor_origin_.head<3>().cast<double>();
    out.hidden.assign(out.current.size(), 0);
    for (std::size_t i = 0; i < out.current.size(); ++i) {
      const Eigen::Vector3d p = out.current[i].getVector3fMap().cast<double>();
      if (!p.allFinite()) continue;
      sim::Ray ray;
      ray.origin = o;
      ray.dir = (p - o).normalized();
      const auto hit = out.s.current_world.intersect(ray, (p - o).norm() - 0.05);
      out.hidden[i] = hit && hit->object_id > 0;
    }
    return out;
  }();
  return r;
}

template <class A, class B>
void addScores(benchmark::State& state, const std::string& prefix, const std::vector<A>& found,
               const std::vector<B>& truth) {
  long tp = 0, fp = 0, fn = 0;
  for (std::size_t i = 0; i < found.size(); ++i) {
    tp += found[i] > 0 && truth[i] > 0;
    fp += found[i] > 0 && !(truth[i] > 0);
    fn += !(found[i] > 0) && truth[i] > 0;
  }
  state.counters[prefix + "precision"] = tp + fp ? double(tp) / (tp + fp) : 0.0;
  state.counters[prefix + "recall"] = tp + fn ? double(tp) / (tp + fn) : 0.0;
  state.counters[prefix + "f1"] = tp ? 2.0 * tp / (2.0 * tp + fp + fn) : 0.0;
}

void BM_RangeImageBuild(benchmark::State& state) {
  const Removal& r = removal();
  const Eigen::Vector3f o = r.reference.sensor_origin_.head<3>();
  RangeImage image;
  for (auto _ : state) image.build(r.reference, {}, o, rangeImageConfig(VisibilityParams()));
  std::size_t occupied = 0;
  for (const auto& p : r.reference)
    occupied += image.classify(p.getVector3fMap(), 0.05) == Visibility::kOccupied;
  state.counters["points"] = static_cast<double>(r.reference.size());
  state.counters["cell_deg"] = image.cellRad() * 180.0 / M_PI;
  state.counters["fill_rows"] = image.fillRows();
  state.counters["fill_cols"] = image.fillCols();
  state.counters["cells"] = static_cast<double>(image.cols()) * image.rows();
  state.counters["own_points_occupied"] = double(occupied) / r.reference.size();
}
BENCHMARK(BM_RangeImageBuild)->Unit(benchmark::kMillisecond);

void BM_NewlyVisible(benchmark::State& state) {
  const Removal& r = removal();
  RangeImage image;
  image.build(r.reference, {}, r.reference.sensor_origin_.head<3>(),
              rangeImageConfig(VisibilityParams()));
  ReferenceVisibility views;
  views.add(image);
  NearestNeighbourIndex map;
  map.build(r.reference);
  const std::vector<int> labels(r.current.size(), 0);
  const double tau = 0.1;
  std::vector<std::uint8_t> nv;
  for (auto _ : state)
    nv = newlyVisible(r.current, labels, views, tau,
                      [&map, tau](const Eigen::Vector3f& p) { return !map.within(p, tau); });
  addScores(state, "", nv, r.hidden);
  state.counters["points"] = static_cast<double>(r.current.size());
}
BENCHMARK(BM_NewlyVisible)->Unit(benchmark::kMillisecond);

void BM_Disappearances(benchmark::State& state) {
  const Removal& r = removal();
  Indices all;
  for (std::size_t i = 0; i < r.reference.size(); ++i) all.push_back(static_cast<int>(i));
  const Params params;
  Result result;
  for (auto _ : state) findDisappearances(params, r.reference, all, r.current, 0.1, &result);
  addScores(state, "", result.disappeared_labels, r.box);
  state.counters["segments"] = static_cast<double>(result.disappeared_segments.size());
}
BENCHMARK(BM_Disappearances)->Unit(benchmark::kMillisecond);

void BM_Detect(benchmark::State& state) {
  const Removal& r = removal();
  Params params;
  params.superquadric.enabled = false;
  // arg 0: every viewpoint stage off (the point rule of visibility.h, hidden segments and
  // their continuations, newly visible, disappearances); arg 1: the defaults (all on).
  const bool on = state.range(0) != 0;
  params.segmentation.visibility_check = on;
  params.segmentation.hidden.segments = on;
  params.segmentation.hidden.continuations = on;
  params.visibility.newly_visible = on;
  params.visibility.disappearances = on;
  Pipeline pipeline(params);
  pipeline.setReference(r.reference);
  Result result;
  std::map<std::string, double> stage_ms;
  for (auto _ : state) {
    result = pipeline.detect(r.current);
    for (const auto& t : result.timings) stage_ms[t.stage] += t.ms;
  }
  const double n = static_cast<double>(state.iterations());
  for (const char* stage :
       {"newly_visible", "disappearances", "hidden_segments", "hidden_continuations"})
    if (stage_ms.count(stage)) state.counters[std::string(stage) + "_ms"] = stage_ms[stage] / n;
  std::size_t novel = 0;
  for (int l : result.labels) novel += l > 0;
  state.counters["false_novel_points"] = static_cast<double>(novel);
  if (state.range(0)) {
    addScores(state, "gone_", result.disappeared_labels, r.box);
    addScores(state, "nv_", result.newly_visible, r.hidden);
  }
  state.counters["points"] = static_cast<double>(r.current.size());
}
BENCHMARK(BM_Detect)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
