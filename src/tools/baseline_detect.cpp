// baseline_detect: the voxel-difference baseline (PCL OctreePointCloudChangeDetector +
// Euclidean clustering) with novelty_detect's output contract, for comparisons.
//
//   baseline_detect --reference REF.pcd --current CUR.pcd --out DIR [--config FILE.yaml]
//
// Writes DIR/labels.txt (one label per point of CUR, 0 or the segment id, input order),
// DIR/disappeared_labels.txt (one per point of REF, the same run with the roles swapped)
// and DIR/report.json (voxel edge, segment counts, time). Exits non-zero with one line on
// stderr for bad arguments, unreadable input or invalid options.
#include <nlohmann/json.hpp>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <stdexcept>
#include <string>

#include "novelty_detection/eval/baseline.h"
#include "novelty_detection/eval/evaluation.h"
#include "novelty_detection/io/cloud_io.h"
#include "tool_main.h"

namespace nd = novelty_detection;

namespace {

constexpr const char* kUsage =
    "usage: baseline_detect --reference REF.pcd|.ply --current CUR.pcd|.ply --out DIR "
    "[--config FILE.yaml]\n"
    "  FILE.yaml keys (optional, top level or under baseline:): resolution_m (0 = "
    "resolution_factor x median point spacing), resolution_factor, cluster_tolerance_factor, "
    "min_cluster_size";

struct Args {
  std::string reference, current, out, config;
};

Args parseArgs(int argc, char** argv) {
  Args a;
  std::map<std::string, std::string*> opts{{"--reference", &a.reference},
                                           {"--current", &a.current},
                                           {"--out", &a.out},
                                           {"--config", &a.config}};
  for (int i = 1; i < argc; ++i) {
    const std::string key = argv[i];
    if (key == "--help" || key == "-h") {
      std::cout << kUsage << "\n";
      std::exit(0);
    }
    const auto it = opts.find(key);
    if (it == opts.end()) throw std::invalid_argument("unknown argument '" + key + "'");
    if (i + 1 >= argc) throw std::invalid_argument(key + " needs a value");
    *it->second = argv[++i];
  }
  if (a.reference.empty() || a.current.empty() || a.out.empty())
    throw std::invalid_argument("--reference, --current and --out are required");
  return a;
}

int run(const Args& args) {
  const nd::BaselineOptions options =
      args.config.empty() ? nd::BaselineOptions{} : nd::loadBaselineOptions(args.config);
  const nd::Cloud reference = nd::loadCloud(args.reference);
  const nd::Cloud current = nd::loadCloud(args.current);
  std::filesystem::create_directories(args.out);
  const auto t0 = std::chrono::steady_clock::now();
  const nd::BaselineResult r = nd::detectChangesBaseline(reference, current, options);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  const std::filesystem::path dir(args.out);
  nd::writeLabelFile((dir / "labels.txt").string(), r.labels);
  nd::writeLabelFile((dir / "disappeared_labels.txt").string(), r.disappeared_labels);
  const nlohmann::json report = {
      {"method", "octree_change_detector+euclidean_clustering"},
      {"resolution_m", r.resolution_m},
      {"cluster_tolerance_m", options.cluster_tolerance_factor * r.resolution_m},
      {"min_cluster_size", options.min_cluster_size},
      {"segments", r.segments},
      {"disappeared_segments", r.disappeared_segments},
      {"detection_ms", ms}};
  std::ofstream f(dir / "report.json");
  f << report.dump(2) << "\n";
  if (!f.flush()) throw std::runtime_error((dir / "report.json").string() + ": cannot write");
  std::cout << "baseline_detect: voxel " << r.resolution_m << " m, " << r.segments
            << " segment(s), " << r.disappeared_segments << " disappearance segment(s), " << ms
            << " ms\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return novelty_detection::runTool("baseline_detect", std::string("\n") + kUsage, argc, argv,
                                    parseArgs, run);
}
