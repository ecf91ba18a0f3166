// A patrol-route map: a 20-sweep reference (about 600k points) read from its directory and
// modelled, and a 30k-point sweep detected against it and against one sweep, each with the
// accuracy it reached as counters:
//   RouteMapLoad     loadReference(DIR) of the 20 PCD sweeps + Pipeline::setReference
//   RouteDetect/0    the sweep against the route sweep nearest it (one viewpoint)
//   RouteDetect/1    the sweep against the whole route map (20 viewpoints)
//
//   bench_route --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <unistd.h>

#include <filesystem>
#include <string>

#include "novelty_detection/eval/evaluation.h"
#include "novelty_detection/io/cloud_io.h"
#include "novelty_detection/io/reference_sweeps.h"
#include "novelty_detection/pipeline.h"
#include "novelty_detection/sim/route.h"

using namespace novelty_detection;

namespace {

struct Route {
  sim::RouteScene scene;
  std::string dir;
  ~Route() { std::filesystem::remove_all(dir); }
};

const Route& route() {
  static const Route r = [] {
    sim::RouteConfig c = sim::routeSceneConfig(0, 1);
    c.reference_sweeps = 20;
    c.sequence_sweeps = 1;
    Route out;
    out.scene = sim::generateRoute(c);
    out.dir = (std::filesystem::temp_directory_path() / ("bench_route_" + std::to_string(getpid())))
                  .string();
    std::vector<CloudFile> sweeps;
    for (const auto& s : out.scene.reference) sweeps.push_back({s.cloud, s.T_world_sensor});
    saveReferenceSweeps(out.dir, sweeps);
    return out;
  }();
  return r;
}

void BM_RouteMapLoad(benchmark::State& state) {
  const Route& r = route();
  std::size_t points = 0, sweeps = 0;
  for (auto _ : state) {
    const ReferenceMap map = loadReference(r.dir);
    Pipeline pipeline{Params()};
    pipeline.setReference(map.cloud, map.views);
    points = map.cloud.size();
    sweeps = map.views.origins.size();
    benchmark::DoNotOptimize(pipeline.referenceViewpoints());
  }
  state.counters["points"] = static_cast<double>(points);
  state.counters["sweeps"] = static_cast<double>(sweeps);
}
BENCHMARK(BM_RouteMapLoad)->Unit(benchmark::kMillisecond);

void BM_RouteDetect(benchmark::State& state) {
  const Route& r = route();
  const bool whole = state.range(0) == 1;
  ReferenceViews views;
  const Cloud map = whole ? sim::mergedReference(r.scene, &views)
                          : sim::mergedReference(r.scene, nullptr, r.scene.nearest_reference);
  Pipeline pipeline{Params()};
  pipeline.setReference(map, views);
  const sim::RouteSweep& sweep = r.scene.sequence.front();
  Result result;
  for (auto _ : state) {
    result = pipeline.detect(sweep.cloud);
    benchmark::DoNotOptimize(result.labels.data());
  }
  const SceneScore score = scoreLabels(result.labels, sweep.labels);
  state.counters["map_points"] = static_cast<double>(map.size());
  state.counters["F1"] = score.f1;
  state.counters["success"] = score.success;
  state.counters["segments"] = static_cast<double>(result.segments.size());
}
BENCHMARK(BM_RouteDetect)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
