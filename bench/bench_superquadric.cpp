// Superquadric recovery speed with its accuracy beside it: one fit versus the number of
// points, and the whole shape retrieval (multi-scale fit + split and merge) of a scene with
// three novelties. Accuracy counters are in millimetres.
//   bench_superquadric --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <random>

#include "../test/unit/superquadric_samples.h"
#include "novelty_detection/shape/shape_retrieval.h"
#include "novelty_detection/shape/split_merge.h"
#include "novelty_detection/shape/superquadric.h"
#include "novelty_detection/shape/superquadric_fit.h"
#include "novelty_detection/sim/scene.h"

using namespace novelty_detection;
using samples::makeSq;

namespace {

constexpr double kSigma = 0.005;

/// A box seen from one side by a sensor 3 m away, noise 5 mm.
Points3d boxView(int n, Superquadric* truth_out) {
  std::mt19937 rng(42);
  Superquadric truth = makeSq({0.3, 0.2, 0.45}, 0.2, 0.2);
  samples::randomPose(truth, rng);
  const Eigen::Vector3d sensor = truth.position + Eigen::Vector3d(-3.0, 0.5, 1.0);
  // About half of the surface faces the sensor.
  const Points3d pts = samples::noisySamples(truth, 2 * n, kSigma, 7u, &sensor);
  *truth_out = truth;
  return subsample(pts, n);
}

void BM_FitOneSuperquadric(benchmark::State& state) {
  Superquadric truth;
  const Points3d pts = boxView(static_cast<int>(state.range(0)), &truth);
  const SuperquadricFitter fitter{SuperquadricParams()};
  FitResult r;
  for (auto _ : state) {
    r = fitter.fit(pts);
    benchmark::DoNotOptimize(r);
  }
  const Eigen::Vector3d sensor = truth.position + Eigen::Vector3d(-3.0, 0.5, 1.0);
  state.counters["points"] = static_cast<double>(pts.size());
  state.counters["mean_radial_mm"] = 1e3 * r.mean_radial_distance;
  state.counters["visible_surface_mm"] =
      1e3 * meanRadialDistance(r.sq, samples::noisySamples(truth, 2000, 0.0, 9u, &sensor));
}
BENCHMARK(BM_FitOneSuperquadric)
    ->Arg(100)
    ->Arg(500)
    ->Arg(2000)
    ->Arg(10000)
    ->Unit(benchmark::kMillisecond);

/// One LM run (no multi-start) from the moment initialisation.
void BM_RefineFromMoments(benchmark::State& state) {
  Superquadric truth;
  const Points3d pts = boxView(static_cast<int>(state.range(0)), &truth);
  const SuperquadricFitter fitter{SuperquadricParams()};
  const Superquadric init = fitter.initialGuesses(pts).front();
  FitResult r;
  for (auto _ : state) {
    r = fitter.refine(pts, init);
    benchmark::DoNotOptimize(r);
  }
  state.counters["points"] = static_cast<double>(pts.size());
  state.counters["iterations"] = r.iterations;
  state.counters["mean_radial_mm"] = 1e3 * r.mean_radial_distance;
}
BENCHMARK(BM_RefineFromMoments)->Arg(100)->Arg(500)->Arg(2000)->Unit(benchmark::kMillisecond);

struct Novelty {
  std::vector<Superquadric> truth;
  Points3d fine;
  Points3d coarse;
};

/// Visible, noisy surface of a union of superquadrics seen from `sensor`.
Novelty makeNovelty(const std::vector<Superquadric>& parts, int per_part,
                    const Eigen::Vector3d& sensor, unsigned seed) {
  Novelty n;
  n.truth = parts;
  for (std::size_t k = 0; k < parts.size(); ++k) {
    for (const auto& p : samples::noisySamples(parts[k], per_part, kSigma, seed + k, &sensor)) {
      bool hidden = false;
      for (std::size_t m = 0; m < parts.size(); ++m) {
        hidden = hidden || (m != k && insideOutside(parts[m], p) < 1.0);
      }
      if (!hidden) n.fine.push_back(p);
    }
  }
  n.coarse = subsample(n.fine, static_cast<int>(n.fine.size() / 10));
  return n;
}

std::vector<Novelty> scene() {
  const Eigen::Vector3d sensor(0.0, 0.0, 1.2);
  std::vector<Novelty> s;
  // A box (a crate), a cylinder (a bin), a person-like composite.
  s.push_back(makeNovelty({makeSq({0.3, 0.25, 0.3}, 0.15, 0.15, {0.4, 0, 0}, {3.0, 1.0, 0.3})},
                          2500, sensor, 1u));
  s.push_back(makeNovelty({makeSq({0.2, 0.2, 0.45}, 0.1, 1.0, {0, 0, 0}, {3.5, -1.0, 0.45})}, 2500,
                          sensor, 2u));
  s.push_back(makeNovelty({makeSq({0.10, 0.18, 0.28}, 0.3, 0.3, {0, 0, 0}, {4.0, 0, 1.2}),
                           makeSq({0.09, 0.09, 0.11}, 1.0, 1.0, {0, 0, 0}, {4.0, 0, 1.6}),
                           makeSq({0.06, 0.06, 0.42}, 0.2, 1.0, {0, 0, 0}, {4.0, -0.09, 0.45}),
                           makeSq({0.06, 0.06, 0.42}, 0.2, 1.0, {0, 0, 0}, {4.0, 0.09, 0.45}),
                           makeSq({0.05, 0.05, 0.30}, 0.2, 1.0, {0, 0, 0}, {4.0, -0.25, 1.15}),
                           makeSq({0.05, 0.05, 0.30}, 0.2, 1.0, {0, 0, 0}, {4.0, 0.25, 1.15})},
                          1200, sensor, 3u));
  return s;
}

/// arg: threads (compute/threads; 1 = the single-thread figure). Time is wall clock, CPU
/// time that of the whole process (all threads).
void BM_ShapeRetrievalThreeNovelties(benchmark::State& state) {
  const std::vector<Novelty> novelties = scene();
  ShapeRetrieval retrieval{SuperquadricParams()};
  retrieval.setThreads(static_cast<int>(state.range(0)));
  std::vector<std::vector<Superquadric>> out(novelties.size());
  for (auto _ : state) {
    for (std::size_t k = 0; k < novelties.size(); ++k) {
      out[k] = retrieval.recover(novelties[k].fine, novelties[k].coarse, static_cast<int>(k + 1));
    }
    benchmark::DoNotOptimize(out);
  }
  // Accuracy: points to their assigned superquadric (radial, mm), and the true parts'
  // clean visible surface to the nearest recovered superquadric (mm).
  double point_sum = 0.0, truth_sum = 0.0;
  std::size_t points = 0, truth_n = 0, parts = 0;
  const Eigen::Vector3d sensor(0.0, 0.0, 1.2);
  for (std::size_t k = 0; k < novelties.size(); ++k) {
    parts += out[k].size();
    for (const auto& sq : out[k]) {
      for (int i : sq.indices) point_sum += radialDistance(sq, novelties[k].fine[i]);
      points += sq.indices.size();
    }
    for (const auto& t : novelties[k].truth) {
      for (const auto& p : samples::noisySamples(t, 300, 0.0, 11u, &sensor)) {
        double best = 1e9;
        for (const auto& sq : out[k]) best = std::min(best, radialDistance(sq, p));
        truth_sum += best;
        ++truth_n;
      }
    }
  }
  state.counters["points"] = static_cast<double>(points);
  state.counters["superquadrics"] = static_cast<double>(parts);
  state.counters["point_error_mm"] = 1e3 * point_sum / std::max<std::size_t>(points, 1);
  state.counters["truth_error_mm"] = 1e3 * truth_sum / std::max<std::size_t>(truth_n, 1);
}
BENCHMARK(BM_ShapeRetrievalThreeNovelties)
    ->Arg(1)
    ->Arg(2)
    ->MeasureProcessCPUTime()
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

/// One novelty of the scene: 0 box, 1 cylinder, 2 person-like composite.
void BM_ShapeRetrievalOneNovelty(benchmark::State& state) {
  const Novelty n = scene()[static_cast<std::size_t>(state.range(0))];
  ShapeRetrieval retrieval{SuperquadricParams()};
  retrieval.setThreads(1);
  std::vector<Superquadric> out;
  for (auto _ : state) {
    out = retrieval.recover(n.fine, n.coarse, 1);
    benchmark::DoNotOptimize(out);
  }
  double sum = 0.0;
  for (const auto& sq : out) {
    for (int i : sq.indices) sum += surfaceDistance(sq, n.fine[i]);
  }
  state.counters["points"] = static_cast<double>(n.fine.size());
  state.counters["superquadrics"] = static_cast<double>(out.size());
  state.counters["point_distance_mm"] = 1e3 * sum / static_cast<double>(n.fine.size());
}
BENCHMARK(BM_ShapeRetrievalOneNovelty)->DenseRange(0, 2)->Unit(benchmark::kMillisecond);

/// Split and merge alone on the person-like composite, memoized or not (arg 1 / 0).
void BM_SplitMergePerson(benchmark::State& state) {
  const SuperquadricParams params;
  const Points3d pts = subsample(scene()[2].fine, params.split_max_points);
  SplitMerge sm(params);
  sm.setMemoize(state.range(0) != 0);
  sm.setThreads(1);
  std::vector<SuperquadricPart> parts;
  for (auto _ : state) {
    parts = sm.run(pts);
    benchmark::DoNotOptimize(parts);
  }
  state.counters["leaves"] = sm.stats().leaves;
  state.counters["merges"] = sm.stats().merges;
  state.counters["merge_fits"] = sm.stats().merge_fits;
  state.counters["neighbour_pairs"] = sm.stats().neighbour_pairs;
  state.counters["noise_mm"] = 1e3 * sm.stats().noise_m;
  state.counters["parts"] = static_cast<double>(parts.size());
  double sum = 0.0;
  for (const auto& p : parts) {
    for (int i : p.indices) sum += surfaceDistance(p.fit.sq, pts[static_cast<std::size_t>(i)]);
  }
  state.counters["point_distance_mm"] = 1e3 * sum / static_cast<double>(pts.size());
}
BENCHMARK(BM_SplitMergePerson)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond);

/// Shape retrieval on one object of the tilting-laser simulator (one-sided, range noise
/// variance 0.001 m^2 as in the paper), seeds 3..5: arg = sim::NoveltyKind (0 box,
/// 1 cylinder, 2 sphere, 3 superellipsoid, 4 person). Counters: superquadrics per object (a
/// simple shape should stay one), the mean distance of the points to their part, and of the
/// true parts' surface where the sensor saw it to the nearest recovered part (mm).
void BM_ShapeRetrievalLaser(benchmark::State& state) {
  struct Object {
    Points3d fine, coarse;
    std::vector<Superquadric> truth;
  };
  std::vector<Object> objects;
  for (std::uint64_t seed : {3u, 4u, 5u}) {
    sim::SceneConfig cfg;
    cfg.seed = seed;
    cfg.novelty_kinds = {static_cast<sim::NoveltyKind>(state.range(0))};
    const sim::ScenePair scene = sim::generateScenePair(cfg);
    if (scene.objects.empty()) continue;
    Object o;
    for (std::size_t i = 0; i < scene.current.size(); ++i) {
      if (scene.current_labels[i] != scene.objects.front().id) continue;
      const auto& p = scene.current[i];
      o.fine.emplace_back(p.x, p.y, p.z);
    }
    for (const auto& part : scene.objects.front().parts) o.truth.push_back(part.sq);
    o.coarse = subsample(o.fine, static_cast<int>(o.fine.size() / 8) + 11);
    objects.push_back(std::move(o));
  }
  ShapeRetrieval retrieval{SuperquadricParams()};
  retrieval.setThreads(1);
  std::vector<std::vector<Superquadric>> out(objects.size());
  for (auto _ : state) {
    for (std::size_t k = 0; k < objects.size(); ++k)
      out[k] = retrieval.recover(objects[k].fine, objects[k].coarse, 1);
    benchmark::DoNotOptimize(out);
  }
  double parts = 0, point_sum = 0, truth_sum = 0;
  std::size_t points = 0, truth_n = 0;
  for (std::size_t k = 0; k < objects.size(); ++k) {
    parts += static_cast<double>(out[k].size());
    for (const auto& sq : out[k]) {
      for (int i : sq.indices) point_sum += surfaceDistance(sq, objects[k].fine[i]);
      points += sq.indices.size();
    }
    for (const auto& t : objects[k].truth) {
      for (const auto& p : sampleSurfaceRandom(t, 400, 5u)) {
        double near = 1e9;
        for (const auto& q : objects[k].fine) near = std::min(near, (q - p).norm());
        if (near > 0.05) continue;  // not seen by the sensor
        double best = 1e9;
        for (const auto& sq : out[k]) best = std::min(best, surfaceDistance(sq, p));
        truth_sum += best;
        ++truth_n;
      }
    }
  }
  state.counters["objects"] = static_cast<double>(objects.size());
  state.counters["superquadrics_per_object"] =
      parts / static_cast<double>(std::max<std::size_t>(objects.size(), 1));
  state.counters["point_distance_mm"] = 1e3 * point_sum / std::max<std::size_t>(points, 1);
  state.counters["truth_error_mm"] = 1e3 * truth_sum / std::max<std::size_t>(truth_n, 1);
}
BENCHMARK(BM_ShapeRetrievalLaser)->DenseRange(0, 4)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
