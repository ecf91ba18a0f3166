// Speed of the novelty detection stages, each with the accuracy it reached as a counter:
// EM (mean error of recovered means), EMD (value), greedy selection (added Gaussians found)
// and end-to-end detection on simulated sweeps of ~3k, ~30k and ~100k points (point F1
// against exact ground truth, scene success as defined in evaluation.h).
//
//   bench_detection --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
// (in .ws/devel/lib/novelty_detection/); --benchmark_filter=Suite runs the 30-scene suites.
#include <benchmark/benchmark.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <map>
#include <memory>
#include <random>

#include "novelty_detection/eval/evaluation.h"
#include "novelty_detection/eval/shape_evaluation.h"
#include "novelty_detection/mixture/emd.h"
#include "novelty_detection/mixture/gmm.h"
#include "novelty_detection/mixture/novelty_selection.h"
#include "novelty_detection/pipeline.h"
#include "novelty_detection/sim/scene.h"

using namespace novelty_detection;

namespace {

Gmm randomMixture(int k, unsigned seed, double spread = 5.0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-spread, spread), s(0.005, 0.05);
  Gmm g;
  for (int i = 0; i < k; ++i) {
    Gaussian c;
    c.weight = 1.0 / k;
    c.mean = Eigen::Vector3d(u(rng), u(rng), u(rng));
    c.cov = Eigen::Vector3d(s(rng), s(rng), s(rng)).asDiagonal();
    g.components.push_back(c);
  }
  return g;
}

void BM_Em(benchmark::State& state) {
  // Three well separated Gaussians sampled with N points; EM with 3 components.
  const int n = static_cast<int>(state.range(0));
  const Gmm truth = randomMixture(3, 1, 2.0);
  std::mt19937 rng(2);
  std::normal_distribution<double> g(0.0, 1.0);
  WeightedPoints d;
  d.points.resize(3, n);
  for (int i = 0; i < n; ++i) {
    const Gaussian& c = truth.components[i % 3];
    d.points.col(i) =
        c.mean + Eigen::Matrix3d(c.cov.llt().matrixL()) * Eigen::Vector3d(g(rng), g(rng), g(rng));
  }
  GmmParams p;
  p.min_variance_m2 = 1e-6;
  const GmmFitter fitter(p);
  Gmm fit;
  for (auto _ : state) fit = fitter.fit(d, 3);
  double err = 0.0;
  for (const auto& t : truth.components) {
    double best = 1e9;
    for (const auto& f : fit.components) best = std::min(best, (f.mean - t.mean).norm());
    err = std::max(err, best);
  }
  state.counters["max_mean_err_m"] = err;
  state.SetItemsProcessed(state.iterations() * n);
}
BENCHMARK(BM_Em)->Arg(3000)->Arg(30000)->Arg(100000)->Unit(benchmark::kMillisecond);

void BM_Emd(benchmark::State& state) {
  const int k = static_cast<int>(state.range(0));
  const Gmm a = randomMixture(k, 3), b = randomMixture(k, 4);
  double value = 0.0;
  for (auto _ : state) value = emd(a, b, GroundDistance::kWasserstein);
  state.counters["emd_m"] = value;
  state.counters["symmetric_err"] = std::abs(value - emd(b, a, GroundDistance::kWasserstein));
}
BENCHMARK(BM_Emd)->Arg(16)->Arg(64)->Arg(128)->Unit(benchmark::kMillisecond);

void BM_Selection(benchmark::State& state) {
  // Reference of K Gaussians; current = the same plus two added ones (the second one last).
  const int k = static_cast<int>(state.range(0));
  const Gmm ref = randomMixture(k, 5);
  Gmm cur = ref;
  for (auto& c : cur.components) c.weight *= 0.9;
  Gaussian add;
  add.weight = 0.05;
  add.mean = Eigen::Vector3d(20, 0, 0);
  cur.components.insert(cur.components.begin() + k / 2, add);
  add.mean = Eigen::Vector3d(0, 20, 0);
  cur.components.push_back(add);
  SelectionParams p;
  SelectionResult r;
  for (auto _ : state) r = GreedyNoveltySelector(p).select(cur, ref, 0.01);
  std::vector<int> got = r.novel;
  std::sort(got.begin(), got.end());
  state.counters["exact"] = got == std::vector<int>{k / 2, k + 1};
  state.counters["emd_solves"] = r.exact_evaluations;
}
BENCHMARK(BM_Selection)->Arg(16)->Arg(64)->Arg(128)->Unit(benchmark::kMillisecond);

/// Simulated scene pairs of about 3k, 30k and 100k points (the suite's first scenes).
const sim::ScenePair& scene(int points) {
  static std::map<int, std::unique_ptr<sim::ScenePair>> cache;
  auto& slot = cache[points];
  if (!slot) {
    sim::SceneConfig c = sim::suiteSceneConfig(0, 1);
    if (points <= 3000) c.laser.step_deg = 2.5;  // 28 x 109 beams
    if (points >= 100000) c.laser.lines = 93;    // 93 x 1081 beams
    slot = std::make_unique<sim::ScenePair>(sim::generateScenePair(c));
  }
  return *slot;
}

/// range(0): points; threads: compute/threads (0: default; 1 = the single-thread figure).
void detection(benchmark::State& state, bool superquadrics, int threads) {
  const sim::ScenePair& s = scene(static_cast<int>(state.range(0)));
  Params p;
  p.superquadric.enabled = superquadrics;
  p.compute.threads = threads;
  Pipeline pipeline(p);
  pipeline.setReference(s.reference);
  Result r;
  for (auto _ : state) r = pipeline.detect(s.current);
  const SceneScore sc = scoreLabels(r.labels, s.current_labels);
  state.counters["points"] = static_cast<double>(s.current.size());
  state.counters["f1"] = sc.f1;
  state.counters["success"] = sc.success;
  state.counters["segments"] = static_cast<double>(r.segments.size());
  state.counters["superquadrics"] = static_cast<double>(r.superquadrics.size());
}

void BM_Detect(benchmark::State& state) { detection(state, false, 0); }
BENCHMARK(BM_Detect)->Arg(3000)->Arg(30000)->Arg(100000)->Unit(benchmark::kMillisecond);

/// range(1): threads.
void BM_DetectWithSuperquadrics(benchmark::State& state) {
  detection(state, true, static_cast<int>(state.range(1)));
}
// Wall time; CPU time of the whole process (all threads).
BENCHMARK(BM_DetectWithSuperquadrics)
    ->Args({30000, 1})
    ->Args({30000, 2})
    ->MeasureProcessCPUTime()
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

/// The 30-scene suite of sim::suiteSceneConfig(i, seed) with a range-noise variance of
/// noise_um2 * 1e-6 m^2 (0: the simulator's default), superquadrics off. Counters: scene
/// success rate and mean point F1 (evaluation.h); time = the whole loop (simulation,
/// reference models and detections).
void BM_Suite(benchmark::State& state) {
  const auto seed = static_cast<std::uint64_t>(state.range(0));
  const double noise = static_cast<double>(state.range(1)) * 1e-6;
  Params p;
  p.superquadric.enabled = false;
  int success = 0, scenes = 0;
  double f1 = 0.0;
  std::vector<double> detect_ms;
  for (auto _ : state) {
    success = scenes = 0;
    f1 = 0.0;
    for (int i = 0; i < 30; ++i) {
      sim::SceneConfig c = sim::suiteSceneConfig(i, seed);
      if (noise > 0) c.laser.noise_variance_m2 = noise;
      const sim::ScenePair s = sim::generateScenePair(c);
      Pipeline pipeline(p);
      pipeline.setReference(s.reference);
      const Result r = pipeline.detect(s.current);
      double ms = 0.0;
      for (const auto& t : r.timings) ms += t.ms;
      detect_ms.push_back(ms);
      const SceneScore sc = scoreLabels(r.labels, s.current_labels);
      success += sc.success;
      f1 += sc.f1;
      ++scenes;
    }
  }
  std::sort(detect_ms.begin(), detect_ms.end());
  state.counters["success"] = static_cast<double>(success) / scenes;
  state.counters["mean_f1"] = f1 / scenes;
  state.counters["median_detect_ms"] = detect_ms[detect_ms.size() / 2];
}
BENCHMARK(BM_Suite)
    ->Args({1, 0})
    ->Args({2, 0})
    ->Args({1, 100})
    ->Args({1, 3000})
    ->Iterations(1)
    ->Unit(benchmark::kSecond);

/// Shapes over the 30-scene suite of seed range(0), superquadric/bounded_fit = range(1),
/// superquadric/surface_weight its default when range(2) is 1, else 0 (eq. 3 alone):
/// medians of the superquadric stage and of the whole detection per scene [ms], and what
/// they achieved: scene success, mean F1, each kind's mean semi-axis error [mm] (one-part
/// fits) and mean surface error over the true shape's floor (evaluate's shapes by kind).
void BM_SuiteShapes(benchmark::State& state) {
  const auto seed = static_cast<std::uint64_t>(state.range(0));
  Params p;
  p.superquadric.bounded_fit = state.range(1) != 0;
  if (state.range(2) == 0) p.superquadric.surface_weight = 0.0;
  std::vector<sim::ScenePair> scenes;
  for (int i = 0; i < 30; ++i)
    scenes.push_back(sim::generateScenePair(sim::suiteSceneConfig(i, seed)));
  std::vector<double> shape_ms, detect_ms;
  std::vector<ObjectShapeError> objects;
  int success = 0;
  double f1 = 0.0;
  for (auto _ : state) {
    shape_ms.clear();
    detect_ms.clear();
    objects.clear();
    success = 0;
    f1 = 0.0;
    for (const sim::ScenePair& s : scenes) {
      Pipeline pipeline(p);
      pipeline.setReference(s.reference);
      const Result r = pipeline.detect(s.current);
      double ms = 0.0, sq_ms = 0.0;
      for (const auto& t : r.timings) {
        ms += t.ms;
        if (t.stage == "superquadrics") sq_ms = t.ms;
      }
      detect_ms.push_back(ms);
      shape_ms.push_back(sq_ms);
      const SceneScore sc = scoreLabels(r.labels, s.current_labels);
      success += sc.success;
      f1 += sc.f1;
      std::vector<TrueShape> shapes;
      for (const auto& o : s.objects) {
        TrueShape t;
        t.id = o.id;
        t.type = sim::toString(o.kind);
        for (const auto& part : o.parts) t.parts.push_back(part.sq);
        shapes.push_back(std::move(t));
      }
      for (auto& e : scoreShapesByObject(s.current, s.current_labels, sc, r.superquadrics, shapes))
        objects.push_back(e);
    }
  }
  const auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  state.counters["superquadric_ms"] = median(shape_ms);
  state.counters["detect_ms"] = median(detect_ms);
  state.counters["success"] = static_cast<double>(success) / static_cast<double>(scenes.size());
  state.counters["mean_f1"] = f1 / static_cast<double>(scenes.size());
  for (const KindShapeError& k : summarizeShapesByKind(objects)) {
    if (k.type == "person" || k.type == "moved_object") continue;
    state.counters[k.type + "_axis_mm"] = 1000.0 * k.semi_axis_error_m;
    state.counters[k.type + "_over_floor"] = k.ratio();
  }
}
BENCHMARK(BM_SuiteShapes)
    ->Args({1, 0, 1})
    ->Args({1, 1, 0})
    ->Args({1, 1, 1})
    ->Iterations(1)
    ->Unit(benchmark::kSecond);

}  // namespace

BENCHMARK_MAIN();
