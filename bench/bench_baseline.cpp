// Cost of the voxel-difference baseline (baseline.h) on a 30k-point simulated sweep, per
// scene group of the viewpoint suite (0 same pose, 1 pose offset, 2 localisation error).
// Accuracy counters: point F1 of the appearances and whether the scene succeeded
// (evaluation.h), and the fraction of newly visible points labelled novel.
#include <benchmark/benchmark.h>

#include "novelty_detection/eval/baseline.h"
#include "novelty_detection/eval/evaluation.h"
#include "novelty_detection/sim/scene.h"

using namespace novelty_detection;

namespace {

void BM_BaselineDetect(benchmark::State& state) {
  // Scenes 0, 1, 2 of the viewpoint suite: one per group, appearances only.
  const sim::ScenePair s =
      sim::generateScenePair(sim::viewpointSceneConfig(static_cast<int>(state.range(0)), 1));
  BaselineResult r;
  for (auto _ : state) {
    r = detectChangesBaseline(s.reference, s.current);
    benchmark::DoNotOptimize(r.labels.data());
  }
  const SceneScore score = scoreLabels(r.labels, s.current_labels);
  std::size_t nv = 0, nv_novel = 0;
  for (std::size_t i = 0; i < s.current_newly_visible.size(); ++i) {
    nv += s.current_newly_visible[i];
    nv_novel += s.current_newly_visible[i] && r.labels[i] > 0;
  }
  state.counters["points"] = static_cast<double>(s.current.size());
  state.counters["f1"] = score.f1;
  state.counters["success"] = score.success ? 1.0 : 0.0;
  state.counters["newly_visible_novel"] = nv ? static_cast<double>(nv_novel) / nv : 0.0;
  state.counters["voxel_m"] = r.resolution_m;
}
BENCHMARK(BM_BaselineDetect)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
