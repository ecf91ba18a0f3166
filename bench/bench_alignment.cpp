// Speed of the fine alignment stage (alignment.h) on simulated ~30k-point sweeps with a known
// 2 cm / 0.5 deg localisation error, with the error left after the correction as counters
// (residual_mm at the sensor origin, residual_deg), beside PCL's GICP on the same sample
// size for comparison. Also the reference side (planes, built once per map).
//
//   bench_alignment --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
// (in .ws/devel/lib/novelty_detection/).
#include <benchmark/benchmark.h>

// PCL's GICP instantiates Eigen's umeyama, on which GCC 12 reports a false -Warray-bounds.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Warray-bounds"
#include <pcl/filters/voxel_grid.h>
#include <pcl/registration/gicp.h>
#pragma GCC diagnostic pop

#include <cmath>

#include "novelty_detection/alignment/alignment.h"
#include "novelty_detection/sim/scene.h"

using namespace novelty_detection;

namespace {

constexpr double kDeg = M_PI / 180.0;

struct Case {
  sim::ScenePair scene;
  Eigen::Isometry3d error;  ///< applied to the current sweep
  Cloud current;            ///< error * scene.current
  Eigen::Vector3d origin;   ///< true sensor origin
};

/// Seeds 0..2: a corridor and offices, error 2 cm along a diagonal and 0.5 deg about a
/// tilted axis through the sensor.
const Case& makeCase(int i) {
  static std::vector<Case> cases;
  if (cases.empty()) {
    for (int k = 0; k < 3; ++k) {
      Case c;
      sim::SceneConfig cfg;
      cfg.seed = 21 + k;
      cfg.layout = k == 0 ? sim::Layout::kCorridor : sim::Layout::kOffice;
      cfg.novelty_kinds = {sim::NoveltyKind::kPerson};
      c.scene = sim::generateScenePair(cfg);
      c.origin = c.scene.current.sensor_origin_.head<3>().cast<double>();
      c.error.setIdentity();
      c.error.linear() =
          Eigen::AngleAxisd(0.5 * kDeg, Eigen::Vector3d(1, -1, 2).normalized()).toRotationMatrix();
      c.error.translation() =
          c.origin - c.error.linear() * c.origin + 0.02 * Eigen::Vector3d(1, 1, -1).normalized();
      c.current = transformCloud(c.scene.current, c.error);
      cases.push_back(std::move(c));
    }
  }
  return cases[i];
}

void report(benchmark::State& state, const Case& c, const Eigen::Isometry3d& T) {
  const Eigen::Isometry3d left = T * c.error;
  state.counters["residual_mm"] = (left * c.origin - c.origin).norm() * 1e3;
  state.counters["residual_deg"] = Eigen::AngleAxisd(left.rotation()).angle() / kDeg;
  state.counters["points"] = static_cast<double>(c.current.size());
}

void BM_FineAlignment(benchmark::State& state) {
  const Case& c = makeCase(static_cast<int>(state.range(0)));
  const AlignmentParams p;
  AlignmentReference ref;
  ref.build(c.scene.reference, p);
  const FineAligner aligner(p);
  AlignmentResult a;
  for (auto _ : state) a = aligner.estimate(ref, c.current);
  report(state, c, a.correction);
  state.counters["applied"] = a.applied;
  state.counters["samples"] = a.samples;
  state.counters["iterations"] = a.iterations;
  state.counters["fitness_mm"] = a.fitness_m * 1e3;
}
BENCHMARK(BM_FineAlignment)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

void BM_AlignmentReferencePlanes(benchmark::State& state) {
  const Case& c = makeCase(0);
  const AlignmentParams p;
  AlignmentReference ref;
  for (auto _ : state) ref.build(c.scene.reference, p);
  state.counters["planes"] = static_cast<double>(ref.planeCount());
  state.counters["cell_m"] = ref.cellSize();
}
BENCHMARK(BM_AlignmentReferencePlanes)->Unit(benchmark::kMillisecond);

/// PCL's generalized ICP on voxel-grid samples of both clouds of about the same size as the
/// fine alignment's sample (the alternative the stage was measured against).
void BM_PclGicp(benchmark::State& state) {
  const Case& c = makeCase(static_cast<int>(state.range(0)));
  auto sample = [](const Cloud& in, float leaf) {
    Cloud::Ptr src(new Cloud(in)), out(new Cloud);
    pcl::VoxelGrid<PointT> vg;
    vg.setInputCloud(src);
    vg.setLeafSize(leaf, leaf, leaf);
    vg.filter(*out);
    return out;
  };
  const Cloud::Ptr target = sample(c.scene.reference, 0.1f);
  Eigen::Matrix4f T = Eigen::Matrix4f::Identity();
  int size = 0;
  // The target (map) and its covariances are set once, as a cached reference model would be.
  pcl::GeneralizedIterativeClosestPoint<PointT, PointT> gicp;
  gicp.setInputTarget(target);
  gicp.setMaxCorrespondenceDistance(0.2);
  for (auto _ : state) {
    const Cloud::Ptr source = sample(c.current, 0.1f);
    size = static_cast<int>(source->size());
    gicp.setInputSource(source);
    gicp.setMaximumIterations(30);
    Cloud out;
    gicp.align(out);
    T = gicp.getFinalTransformation();
  }
  Eigen::Isometry3d Td(T.cast<double>());
  report(state, c, Td);
  state.counters["samples"] = size;
}
BENCHMARK(BM_PclGicp)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
