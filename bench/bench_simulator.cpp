// Cost of the scan simulator: superellipsoid ray casting, one sweep, one scene pair.
// Accuracy counters: the superellipsoid's worst axis-ray error against the exact a_i, and
// the points and ground-truth objects produced.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>

#include "novelty_detection/sim/laser.h"
#include "novelty_detection/sim/scene.h"

using namespace novelty_detection;
using namespace novelty_detection::sim;

namespace {

Superquadric shape(double e1, double e2) {
  Superquadric sq;
  sq.a = Eigen::Vector3d(0.3, 0.4, 0.6);
  sq.e1 = e1;
  sq.e2 = e2;
  sq.euler = Eigen::Vector3d(0.3, 0.6, -0.2);
  sq.position = Eigen::Vector3d(1.0, 2.0, 0.6);
  return sq;
}

// Rays from 3 m away towards the superellipsoid's bounding sphere; range(0), range(1) are
// 10 * e1, 10 * e2.
void BM_SuperellipsoidRay(benchmark::State& state) {
  const Superquadric sq = shape(state.range(0) / 10.0, state.range(1) / 10.0);
  const Superellipsoid se(sq);
  Rng rng(1);
  std::vector<Ray> rays(4096);
  for (auto& r : rays) {
    Eigen::Vector3d d(standardNormal(rng), standardNormal(rng), standardNormal(rng));
    r.origin = sq.position + 3.0 * d.normalized();
    Eigen::Vector3d t(standardNormal(rng), standardNormal(rng), standardNormal(rng));
    r.dir = (sq.position + 0.5 * t.normalized() - r.origin).normalized();
  }
  std::size_t i = 0, hits = 0, casts = 0;
  for (auto _ : state) {
    const auto t = se.intersect(rays[i++ & 4095]);
    hits += t.has_value();
    ++casts;
    benchmark::DoNotOptimize(t);
  }
  double max_err = 0.0;
  const Eigen::Matrix3d R = sq.rotation();
  for (int axis = 0; axis < 3; ++axis) {
    const Eigen::Vector3d n = R.col(axis);
    const auto t = se.intersect(Ray{sq.position + 4.0 * n, -n});
    max_err = std::max(max_err, t ? std::abs(*t - (4.0 - sq.a[axis])) : 1e9);
  }
  state.counters["hit_rate"] = static_cast<double>(hits) / std::max<std::size_t>(1, casts);
  state.counters["axis_err_m"] = max_err;
}
BENCHMARK(BM_SuperellipsoidRay)->Args({10, 10})->Args({1, 1})->Args({5, 15})->Args({20, 20});

void BM_TiltSweep(benchmark::State& state) {
  SceneConfig c;
  c.seed = 3;
  c.novelty_kinds = {NoveltyKind::kPerson, NoveltyKind::kSuperellipsoid};
  const ScenePair s = generateScenePair(c);
  std::size_t points = 0;
  for (auto _ : state) {
    const TiltScan scan = simulateTiltScan(s.current_world, s.T_world_sensor_current, c.laser, 1);
    points = scan.cloud.size();
    benchmark::DoNotOptimize(points);
  }
  state.counters["points"] = static_cast<double>(points);
  state.counters["rays_per_s"] = benchmark::Counter(
      static_cast<double>(c.laser.lines * c.laser.beamsPerLine()) * state.iterations(),
      benchmark::Counter::kIsRate);
}
BENCHMARK(BM_TiltSweep)->Unit(benchmark::kMillisecond);

void BM_ScenePair(benchmark::State& state) {
  int index = 0;
  std::size_t points = 0, objects = 0, planned = 0;
  for (auto _ : state) {
    const SceneConfig c = suiteSceneConfig(index++ % 30, 1);
    const ScenePair s = generateScenePair(c);
    points += s.current.size();
    objects += s.objects.size();
    planned += c.novelty_kinds.size();
  }
  state.counters["points"] = static_cast<double>(points) / state.iterations();
  state.counters["objects_placed"] =
      static_cast<double>(objects) / std::max<std::size_t>(1, planned);
}
BENCHMARK(BM_ScenePair)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
