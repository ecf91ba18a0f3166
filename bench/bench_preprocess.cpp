// Pre-processing and multi-scale sampling: speed per stage and for the whole chain at 3k,
// 30k, 100k and 300k points, with the points in/out and the accuracy of each stage as
// counters. Data: seeded synthetic tilting-laser sweeps of a 9 m corridor (walls, ceiling,
// a 10 cm box, a 0.5 m cube), 1 cm range noise, 0.5 % sparse outliers, 1 % NaNs.
//
//   bench_preprocess --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
//   bench_preprocess --dump_multiscale=PREFIX   # writes PREFIX_<noise>.txt for the figure
//   scripts/plot_multiscale.py OUT.png PREFIX_0.0050.txt PREFIX_0.0316.txt
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <string>

#include "../test/unit/synthetic_scene.h"
#include "novelty_detection/preprocess/multiscale_tree.h"
#include "novelty_detection/preprocess/preprocess.h"
#include "novelty_detection/preprocess/self_returns.h"
#include "novelty_detection/sim/scene.h"

namespace nd = novelty_detection;
namespace syn = novelty_detection::synthetic;

namespace {

syn::SceneOptions options(int points, double noise) {
  syn::SceneOptions opt;
  opt.points = points;
  opt.range_sigma_m = noise;
  opt.outlier_fraction = 0.005;
  opt.outlier_clearance_m = 0.2;
  opt.nan_fraction = 0.01;
  opt.seed = 2002;
  opt.room.hi.x() = 6.0;
  return opt;
}

const syn::Scene& scene(int points) {
  static std::map<int, syn::Scene> cache;
  auto it = cache.find(points);
  if (it == cache.end()) it = cache.emplace(points, syn::makeCorridor(options(points, 0.01))).first;
  return it->second;
}

void setInOut(benchmark::State& state, double in, double out) {
  state.counters["points_in"] = in;
  state.counters["points_out"] = out;
}

void BM_OutlierRemoval(benchmark::State& state) {
  const syn::Scene& s = scene(static_cast<int>(state.range(0)));
  const nd::PreprocessParams p;
  const nd::Indices finite = nd::finiteIndices(s.cloud);
  nd::Indices kept, removed;
  for (auto _ : state) {
    kept = nd::removeSparseOutliers(s.cloud, finite, p.outlier_k, p.outlier_std_mul, &removed);
    benchmark::DoNotOptimize(kept.data());
  }
  int outliers = 0, outliers_removed = 0, surface_removed = 0;
  for (int i : finite) outliers += s.label[i] == syn::kOutlier;
  for (int i : removed) (s.label[i] == syn::kOutlier ? outliers_removed : surface_removed)++;
  setInOut(state, finite.size(), kept.size());
  state.counters["outliers_removed_pct"] = 100.0 * outliers_removed / std::max(1, outliers);
  state.counters["surface_removed_pct"] =
      100.0 * surface_removed / std::max<double>(1, finite.size() - outliers);
}

void BM_GroundRemoval(benchmark::State& state) {
  const syn::Scene& s = scene(static_cast<int>(state.range(0)));
  const nd::PreprocessParams p;
  const nd::Indices finite = nd::finiteIndices(s.cloud);
  nd::GroundPlane g;
  for (auto _ : state) {
    g = nd::findGroundPlane(s.cloud, finite, p);
    benchmark::DoNotOptimize(g.inliers.data());
  }
  std::vector<char> on(s.cloud.size(), 0);
  for (int i : g.inliers) on[i] = 1;
  int floor = 0, floor_removed = 0, box = 0, box_kept = 0;
  for (int i : finite) {
    if (s.label[i] == syn::kFloor) {
      ++floor;
      floor_removed += on[i];
    } else if (s.label[i] == syn::kObject && s.cloud[i].z > g.threshold_m + 0.002) {
      ++box;
      box_kept += !on[i];
    }
  }
  setInOut(state, finite.size(), finite.size() - g.inliers.size());
  state.counters["angle_err_deg"] =
      std::acos(std::min(1.0, g.coefficients.head<3>().normalized().z())) * 180 / M_PI;
  state.counters["offset_err_mm"] = 1000 * std::abs(g.coefficients(3));
  state.counters["floor_removed_pct"] = 100.0 * floor_removed / std::max(1, floor);
  state.counters["box_above_kept_pct"] = 100.0 * box_kept / std::max(1, box);
}

void BM_TreeBuild(benchmark::State& state) {
  const syn::Scene& s = scene(static_cast<int>(state.range(0)));
  nd::MultiScaleTree tree;
  for (auto _ : state) {
    tree.build(s.cloud);
    benchmark::DoNotOptimize(tree.nodes().data());
  }
  setInOut(state, tree.order().size(), tree.nodes().size());
  state.counters["noise_std_mm"] = 1000 * std::sqrt(tree.noiseVariance());
}

void BM_Cut(benchmark::State& state) {
  const syn::Scene& s = scene(static_cast<int>(state.range(0)));
  nd::MultiScaleTree tree;
  tree.build(s.cloud);
  const nd::MultiScaleParams p;
  nd::MultiScaleTree::Cut cut;
  for (auto _ : state) {
    cut = tree.cut(p);
    benchmark::DoNotOptimize(cut.points.data());
  }
  setInOut(state, tree.order().size(), cut.points.size());
}

void BM_Preprocessor(benchmark::State& state) {
  const syn::Scene& s = scene(static_cast<int>(state.range(0)));
  const nd::Preprocessor pre{nd::PreprocessParams()};
  nd::PreprocessResult r;
  for (auto _ : state) {
    r = pre.compute(s.cloud);
    benchmark::DoNotOptimize(r.kept.data());
  }
  setInOut(state, s.cloud.size(), r.kept.size());
  state.counters["outliers"] = r.outliers.size();
  state.counters["ground"] = r.ground.inliers.size();
}

/// The whole first stage of the paper: pre-processing, tree, default scale.
void BM_PreprocessAndSample(benchmark::State& state) {
  const syn::Scene& s = scene(static_cast<int>(state.range(0)));
  const nd::Preprocessor pre{nd::PreprocessParams()};
  const nd::MultiScaleParams mp;
  nd::MultiScaleTree tree;
  nd::MultiScaleTree::Cut cut;
  std::size_t kept = 0;
  for (auto _ : state) {
    const nd::PreprocessResult r = pre.compute(s.cloud);
    tree.build(s.cloud, r.kept);
    cut = tree.cut(mp);
    kept = r.kept.size();
    benchmark::DoNotOptimize(cut.points.data());
  }
  setInOut(state, s.cloud.size(), cut.points.size());
  state.counters["preprocessed"] = kept;
}

/// The same chain on the simulator's corridor sweep (28 x 1081 beams, 0.001 m^2 range
/// noise, a box and a sphere as novelties).
void BM_PreprocessAndSampleSimulated(benchmark::State& state) {
  namespace sim = novelty_detection::sim;
  sim::SceneConfig cfg;
  cfg.seed = 3;
  cfg.novelty_kinds = {sim::NoveltyKind::kBox, sim::NoveltyKind::kSphere};
  const sim::ScenePair pair = sim::generateScenePair(cfg);
  const nd::Preprocessor pre{nd::PreprocessParams()};
  const nd::MultiScaleParams mp;
  nd::MultiScaleTree tree;
  nd::MultiScaleTree::Cut cut;
  nd::PreprocessResult r;
  for (auto _ : state) {
    r = pre.compute(pair.current);
    tree.build(pair.current, r.kept);
    cut = tree.cut(mp);
    benchmark::DoNotOptimize(cut.points.data());
  }
  setInOut(state, pair.current.size(), cut.points.size());
  state.counters["preprocessed"] = r.kept.size();
  state.counters["ground_offset_mm"] = 1000 * std::abs(r.ground.coefficients(3));
  int novel = 0, novel_kept = 0;
  std::vector<char> kept(pair.current.size(), 0);
  for (int i : r.kept) kept[i] = 1;
  for (std::size_t i = 0; i < pair.current.size(); ++i) {
    if (pair.current_labels[i] > 0 && pair.current[i].z > r.ground.threshold_m) {
      ++novel;
      novel_kept += kept[i];
    }
  }
  state.counters["novel_above_ground_kept_pct"] = 100.0 * novel_kept / std::max(1, novel);
}

/// The robot-return test on a simulated corridor pair taken 0.3 m apart (most of a corridor
/// sweep lies within self_max_range_m of the sensor): range(0) = 1 keeps the map's side made
/// once, as a map's model does for every sweep after the first that moved; 0 makes it for
/// each sweep. The marks are the same either way.
void BM_SelfReturns(benchmark::State& state) {
  namespace sim = novelty_detection::sim;
  sim::SceneConfig cfg;
  cfg.seed = 3;
  cfg.novelty_kinds = {sim::NoveltyKind::kBox};
  cfg.pose_offset = Eigen::Vector3d(0.3, 0.05, 0.05);
  const sim::ScenePair pair = sim::generateScenePair(cfg);
  const nd::PreprocessParams p;
  const nd::SelfReturnReference prepared(pair.reference, p);
  const nd::SelfReturnReference* use = state.range(0) ? &prepared : nullptr;
  if (use) use->impl();  // made before the timed runs, as by the first sweep
  nd::SelfReturns r;
  for (auto _ : state) {
    r = nd::findSelfReturns(pair.reference, pair.current, p, 0.05, {}, {}, 1, use);
    benchmark::DoNotOptimize(r.current.data());
  }
  state.counters["current_marked"] = static_cast<double>(r.current_count);
  state.counters["reference_marked"] = static_cast<double>(r.reference_count);
  state.counters["tolerance_mm"] = 1000.0 * r.tolerance_m;
}
BENCHMARK(BM_SelfReturns)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

#define SIZES Arg(3000)->Arg(30000)->Arg(100000)->Arg(300000)->Unit(benchmark::kMillisecond)
BENCHMARK(BM_OutlierRemoval)->SIZES;
BENCHMARK(BM_GroundRemoval)->SIZES;
BENCHMARK(BM_TreeBuild)->SIZES;
BENCHMARK(BM_Cut)->SIZES;
BENCHMARK(BM_Preprocessor)->SIZES;
BENCHMARK(BM_PreprocessAndSample)->SIZES;
BENCHMARK(BM_PreprocessAndSampleSimulated)->Unit(benchmark::kMillisecond);

/// Distance from p to the nearest edge of an axis-aligned box (its 12 edges).
double edgeDistance(const Eigen::Vector3d& p, const syn::AlignedBox& b) {
  double best = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    const int u = (a + 1) % 3, v = (a + 2) % 3;
    const double along = std::max({b.lo(a) - p(a), p(a) - b.hi(a), 0.0});
    for (const double eu : {b.lo(u), b.hi(u)}) {
      for (const double ev : {b.lo(v), b.hi(v)}) {
        best = std::min(
            best, std::sqrt(along * along + (p(u) - eu) * (p(u) - eu) + (p(v) - ev) * (p(v) - ev)));
      }
    }
  }
  return best;
}

/// For the figure in docs/algorithm.md: per noise level, the pre-processed 30k sweep at the default
/// scale: "r x y z size" per representative, "p x y z size edge" per point (size of its cluster,
/// true distance to the nearest edge of the scene).
int dumpMultiscale(const std::string& prefix) {
  for (const double noise : {0.005, 0.0316}) {
    const syn::Scene s = syn::makeCorridor(options(30000, noise));
    const nd::PreprocessResult r = nd::Preprocessor(nd::PreprocessParams()).compute(s.cloud);
    nd::MultiScaleTree tree;
    tree.build(s.cloud, r.kept);
    const nd::MultiScaleTree::Cut cut = tree.cut(nd::MultiScaleParams());
    char name[64];
    std::snprintf(name, sizeof(name), "_%.4f.txt", noise);
    const std::string path = prefix + name;
    FILE* f = std::fopen(path.c_str(), "w");
    if (!f) {
      std::fprintf(stderr, "cannot write %s\n", path.c_str());
      return 1;
    }
    std::fprintf(f, "# noise %.4f input %zu preprocessed %zu representatives %zu\n", noise,
                 s.cloud.size(), r.kept.size(), cut.points.size());
    for (std::size_t c = 0; c < cut.points.size(); ++c) {
      std::fprintf(f, "r %.3f %.3f %.3f %d\n", cut.points[c].x(), cut.points[c].y(),
                   cut.points[c].z(), cut.sizes[c]);
    }
    const syn::SceneOptions opt = options(30000, noise);
    for (int i : r.kept) {
      // Ground truth: distance to the nearest edge of the corridor or of an object.
      const Eigen::Vector3d p = s.cloud[i].getVector3fMap().cast<double>();
      double edge = edgeDistance(p, opt.room);
      for (const auto& b : opt.objects) edge = std::min(edge, edgeDistance(p, b));
      std::fprintf(f, "p %.3f %.3f %.3f %d %.3f\n", p.x(), p.y(), p.z(),
                   cut.sizes[cut.cluster_of[i]], edge);
    }
    std::fclose(f);
    std::printf("%s: %zu points -> %zu preprocessed -> %zu representatives\n", path.c_str(),
                s.cloud.size(), r.kept.size(), cut.points.size());
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const char* flag = "--dump_multiscale=";
  for (int i = 1; i < argc; ++i) {
    if (std::strncmp(argv[i], flag, std::strlen(flag)) == 0) {
      return dumpMultiscale(argv[i] + std::strlen(flag));
    }
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
