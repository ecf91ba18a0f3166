// A patrol-route map: a 20-sweep reference (about 600k points) read from its directory and
// modelled, and a 30k-point sweep detected against it and against one sweep, each with the
// accuracy it reached as counters:
//   RouteMapLoad     loadReference(DIR) of the 20 PCD sweeps + Pipeline::setReference
//   RouteDetect/0    the sweep against the route sweep nearest it (one viewpoint)
//   RouteDetect/1    the sweep against the whole route map (20 viewpoints)
//   RouteFreeSpace/0 what the route saw as free: one range image per sweep (the package's way)
//   RouteFreeSpace/1 the same from an OctoMap (5 cm, every beam ray-cast into the octree);
//                    both with the share of the new object's points they call free space
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
#include "novelty_detection/visibility/visibility.h"

#include <octomap/OcTree.h>

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

void BM_RouteFreeSpace(benchmark::State& state) {
  const Route& r = route();
  const bool octree = state.range(0) == 1;
  const sim::RouteSweep& sweep = r.scene.sequence.front();
  std::vector<Eigen::Vector3f> object;
  for (std::size_t i = 0; i < sweep.cloud.size(); ++i)
    if (sweep.labels[i] == sim::kStayingObjectId) object.push_back(sweep.cloud[i].getVector3fMap());
  const double margin_m = 0.1;
  std::size_t free = 0;
  for (auto _ : state) {
    free = 0;
    if (octree) {
      octomap::OcTree tree(0.05);
      for (const auto& s : r.scene.reference) {
        octomap::Pointcloud scan;
        for (const PointT& p : s.cloud) scan.push_back(p.x, p.y, p.z);
        const Eigen::Vector3d o = s.T_world_sensor.translation();
        tree.insertPointCloud(scan, octomap::point3d(o.x(), o.y(), o.z()), 30.0);
      }
      for (const auto& p : object) {
        const octomap::OcTreeNode* n = tree.search(p.x(), p.y(), p.z());
        free += n && !tree.isNodeOccupied(n);
      }
    } else {
      ReferenceVisibility visibility;
      for (const auto& s : r.scene.reference) {
        RangeImage image;
        image.build(s.cloud, {}, s.T_world_sensor.translation().cast<float>(),
                    RangeImage::Config());
        visibility.add(std::move(image));
      }
      for (const auto& p : object) free += visibility.classify(p, margin_m) == Visibility::kFree;
    }
  }
  state.counters["object_points"] = static_cast<double>(object.size());
  state.counters["free_share"] = object.empty() ? 0.0 : static_cast<double>(free) / object.size();
}
BENCHMARK(BM_RouteFreeSpace)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
