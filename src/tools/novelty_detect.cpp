// novelty_detect: compares a current sweep with a reference map (files, exit codes: README.md).
//
//   novelty_detect --reference REF.pcd --current CUR.pcd --out DIR [--config FILE.yaml]
//
// Writes DIR/labels.txt (one label per point of CUR, input order), DIR/superquadrics.json,
// DIR/report.json (with the fine alignment's correction), DIR/segments.pcd (CUR coloured by
// segment, in the map frame when the alignment moved it), DIR/newly_visible.txt (0/1 per
// point of CUR), DIR/disappeared_labels.txt (one label per point of REF, 0 = still there)
// and DIR/disappeared_superquadrics.json (same format as superquadrics.json). Exits non-zero with
// one line on stderr for bad arguments, unreadable input or an invalid configuration.
#include <pcl/io/pcd_io.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>

#include "detect_report.h"
#include "novelty_detection/alignment/alignment.h"
#include "novelty_detection/io/cloud_io.h"
#include "novelty_detection/io/output_set.h"
#include "novelty_detection/io/params_io.h"
#include "novelty_detection/io/reference_cache.h"
#include "novelty_detection/io/reference_sweeps.h"
#include "novelty_detection/pipeline.h"
#include "novelty_detection/preprocess/input_check.h"
#include "novelty_detection/preprocess/sensor_origin.h"
#include "tool_main.h"

namespace nd = novelty_detection;
using nlohmann::json;

namespace {

constexpr const char* kUsage =
    "usage: novelty_detect --reference REF.pcd|.ply|REF_DIR --current CUR.pcd|.ply --out DIR "
    "[--config FILE.yaml] [--reference-origin X Y Z] [--current-origin X Y Z] "
    "[--sensor-frame] [--up X Y Z | --up auto] [--reference-cache DIR] [--repeat N]";

constexpr const char* kHelp = R"(Compares a current cloud with a reference map and writes, into DIR:
labels.txt, superquadrics.json, report.json, segments.pcd, newly_visible.txt,
disappeared_labels.txt and disappeared_superquadrics.json.

  --reference FILE|DIR     the reference map (.pcd or .ply), or a directory of *.pcd sweeps
                           in the map frame, each with VIEWPOINT = the pose it was taken
                           from (what any of them saw through counts as free space)
  --current FILE           the current sweep (.pcd or .ply)
  --out DIR                output directory (created)
  --config FILE            YAML file overriding any parameter (docs/parameters.md)
  --reference-origin X Y Z the reference sensor's position in the clouds' frame [m]
                           (overrides preprocess/reference_origin and the PCD VIEWPOINT;
                           not with a directory)
  --current-origin X Y Z   the same for the current sweep (preprocess/current_origin)
  --sensor-frame           each cloud is in its own sensor's frame: its origin (0, 0, 0) is
                           the sensor (preprocess/sensor_frame). An organised cloud
                           (HEIGHT > 1) is taken as such unless an origin is given or its
                           VIEWPOINT is set.
  --up X Y Z | --up auto   which way is up (preprocess/up; default 0 0 1). auto: estimated
                           from the reference (the floor or table plane below the sensor).
  --reference-cache DIR    keep the reference's model in DIR (created) and read it back on
                           the next run with the same map and settings: the model is built
                           once per map (report.json: reference_cache). Default: off for a
                           file, REF_DIR/.model_cache for a directory; "off" disables it.
  --repeat N               detect the sweep N times (1-1000) in this process: the outputs and
                           report.json's timings_ms are the last detection's, as a running
                           node detects sweep after sweep; report.json's repeated gives the
                           first detection's stage times (a fresh process touching its memory
                           for the first time) and every detection's total. Default 1.
The visibility rules and disappearances need each cloud's sensor origin; without one they
are off, and stderr and report.json (sensor_origins, visibility_checked) say so.
DIR/complete, written last, lists the files of the set: without it a run was interrupted.
Exit codes: 0 done, 1 unreadable or invalid input or configuration, 2 bad arguments,
3 the clouds do not overlap enough to compare (report.json gives "overlap"; never "no change").
)";

/// The clouds do not overlap enough to be compared.
constexpr int kExitNoOverlap = 3;

struct Args {
  std::string reference, current, out, config, up, reference_cache;
  std::optional<Eigen::Vector3f> reference_origin, current_origin;
  bool sensor_frame = false;
  bool help = false;
  int repeat = 1;
};

Eigen::Vector3f parseVector(const std::string& flag, char** values) {
  Eigen::Vector3f v;
  for (int k = 0; k < 3; ++k) {
    char* end = nullptr;
    v[k] = std::strtof(values[k], &end);
    if (end == values[k] || *end != '\0' || !std::isfinite(v[k]))
      throw std::invalid_argument(flag + " needs three finite numbers, got '" +
                                  std::string(values[k]) + "'");
  }
  return v;
}

Args parseArgs(int argc, char** argv) {
  Args a;
  std::map<std::string, std::string*> opts{{"--reference", &a.reference},
                                           {"--current", &a.current},
                                           {"--out", &a.out},
                                           {"--config", &a.config},
                                           {"--reference-cache", &a.reference_cache}};
  for (int i = 1; i < argc; ++i) {
    const std::string key = argv[i];
    if (key == "--help" || key == "-h") {
      a.help = true;
      return a;
    }
    if (key == "--sensor-frame") {
      a.sensor_frame = true;
      continue;
    }
    if (key == "--repeat") {
      if (i + 1 >= argc) throw std::invalid_argument("--repeat needs a count");
      const std::string v = argv[++i];
      char* end = nullptr;
      const long n = std::strtol(v.c_str(), &end, 10);
      if (v.empty() || *end != '\0' || n < 1 || n > 1000)
        throw std::invalid_argument("--repeat needs a whole number from 1 to 1000, got '" + v +
                                    "'");
      a.repeat = static_cast<int>(n);
      continue;
    }
    if (key == "--reference-origin" || key == "--current-origin") {
      if (i + 3 >= argc) throw std::invalid_argument(key + " needs three numbers X Y Z");
      (key == "--reference-origin" ? a.reference_origin : a.current_origin) =
          parseVector(key, argv + i + 1);
      i += 3;
      continue;
    }
    if (key == "--up") {
      if (i + 1 < argc && std::string(argv[i + 1]) == "auto") {
        a.up = "auto";
        ++i;
        continue;
      }
      if (i + 3 >= argc) throw std::invalid_argument("--up needs X Y Z or auto");
      const Eigen::Vector3f v = parseVector(key, argv + i + 1);
      if (v.norm() < 1e-9) throw std::invalid_argument("--up must not be the zero vector");
      std::ostringstream text;
      text << std::setprecision(9) << v.x() << " " << v.y() << " " << v.z();
      a.up = text.str();
      i += 3;
      continue;
    }
    const auto it = opts.find(key);
    if (it == opts.end()) throw std::invalid_argument("unknown argument '" + key + "'");
    if (i + 1 >= argc) throw std::invalid_argument(key + " needs a value");
    *it->second = argv[++i];
  }
  if (a.reference.empty() || a.current.empty() || a.out.empty()) {
    throw std::invalid_argument("--reference, --current and --out are required");
  }
  return a;
}

int run(const Args& args) {
  if (args.help) {
    std::cout << kUsage << "\n\n" << kHelp;
    return 0;
  }
  nd::Params params;
  if (!args.config.empty()) nd::loadParamsYaml(args.config, params);
  if (!args.up.empty()) params.preprocess.up = args.up;
  // loadCloud keeps the PCD VIEWPOINT as the cloud's sensor origin; the flags override it.
  // Both clouds get preprocess/max_points, checked on the file's header before its body.
  nd::LoadLimits limits;
  limits.max_points = static_cast<std::uint64_t>(params.preprocess.max_points);
  nd::ReferenceMap map = nd::loadReference(args.reference, limits);
  nd::Cloud& reference = map.cloud;
  nd::Cloud current = nd::loadCloud(args.current, limits);
  nd::cli::Assumptions as;
  // The flags override the configuration (preprocess/reference_origin, current_origin,
  // sensor_frame), which overrides the files' VIEWPOINT.
  const bool sensor_frame = args.sensor_frame || params.preprocess.sensor_frame;
  auto origin = [&](nd::Cloud& cloud, const std::optional<Eigen::Vector3f>& flag, const char* param,
                    const std::string& configured) {
    return nd::resolveOrigin(cloud, flag ? flag : nd::parseOrigin(param, configured), sensor_frame);
  };
  if (!map.views.empty()) {
    // A reference directory: each sweep's VIEWPOINT is its origin (io/reference_sweeps.h).
    if (args.reference_origin ||
        nd::parseOrigin("preprocess/reference_origin", params.preprocess.reference_origin))
      throw std::invalid_argument(
          "--reference-origin and preprocess/reference_origin do not apply to a reference "
          "directory: each sweep's VIEWPOINT is its sensor origin");
    as.reference_origin = "sweep viewpoints";
  } else {
    as.reference_origin = origin(reference, args.reference_origin, "preprocess/reference_origin",
                                 params.preprocess.reference_origin);
  }
  as.reference_sweeps = map.views.empty() ? 1 : map.views.origins.size();
  as.current_origin = origin(current, args.current_origin, "preprocess/current_origin",
                             params.preprocess.current_origin);
  as.reference = &reference;
  as.current = &current;
  as.visibility_checked = params.segmentation.visibility_check &&
                          (!map.views.empty() || nd::sensorOriginKnown(reference.sensor_origin_));
  if (params.segmentation.visibility_check && !as.visibility_checked)
    std::cerr << "novelty_detect: the reference's sensor origin is unknown (no VIEWPOINT): "
                 "the visibility rules are off; give --reference-origin X Y Z or "
                 "--sensor-frame\n";
  // The output files are written as one set (staged, then renamed in, `complete` last).
  nd::OutputSet out(args.out);

  using Clock = std::chrono::steady_clock;
  nd::Pipeline pipeline(params);
  auto t0 = Clock::now();
  // A route map (a directory) keeps its model beside its sweeps unless told otherwise.
  std::string cache_dir = args.reference_cache;
  if (cache_dir.empty() && nd::isDirectory(args.reference))
    cache_dir = (std::filesystem::path(args.reference) / ".model_cache").string();
  if (cache_dir.empty() || cache_dir == "off") {
    pipeline.setReference(reference, map.views);
    as.cache.state = "off";
  } else {
    as.cache = nd::setReferenceCached(pipeline, reference, map.views, cache_dir);
    if (!as.cache.message.empty()) std::cerr << "novelty_detect: " << as.cache.message << "\n";
  }
  auto t1 = Clock::now();
  const double ref_ms = std::chrono::duration<double, std::milli>(t1 - t0).count();
  // --repeat: the same sweep again in this process; what is written is the last detection's.
  nd::Result result;
  std::vector<double> runs_ms;
  json first_timings;
  bool identical = true;
  std::vector<int> first_labels, first_gone;
  for (int run = 0; run < args.repeat; ++run) {
    t1 = Clock::now();
    try {
      result = pipeline.detect(current);
    } catch (const nd::NoOverlapError& e) {
      // Not "no change": the set holds only a report saying why nothing was compared.
      out.writeText(
          "report.json",
          json({{"overlap", e.overlap()}, {"compared", false}, {"error", e.what()}}).dump(2) +
              "\n");
      out.commit();
      std::cerr << "novelty_detect: " << e.what() << "\n";
      return kExitNoOverlap;
    }
    runs_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t1).count());
    if (args.repeat == 1) break;
    std::cout << "novelty_detect: detection " << run + 1 << " of " << args.repeat << ", "
              << runs_ms.back() << " ms\n";
    if (run == 0) {
      first_timings = nd::cli::timingsJson(result, runs_ms.front());
      first_labels = result.labels;
      first_gone = result.disappeared_labels;
    } else {
      identical =
          identical && result.labels == first_labels && result.disappeared_labels == first_gone;
    }
  }
  if (!identical)
    std::cerr << "novelty_detect: the repeated detections of the sweep differ; the last one is "
                 "written\n";
  const double det_ms = runs_ms.back();

  std::string labels;
  labels.reserve(result.labels.size() * 2);
  for (int l : result.labels) labels += std::to_string(l) + '\n';
  out.writeText("labels.txt", labels);
  out.writeText("superquadrics.json",
                nd::cli::superquadricsJson(result.superquadrics).dump(2) + "\n");
  // Visibility outputs: newly visible flags per current point, disappearance
  // labels per reference point (same convention as labels.txt) and their superquadrics.
  std::string flags;
  flags.reserve(result.newly_visible.size() * 2);
  for (auto f : result.newly_visible) flags += f ? "1\n" : "0\n";
  out.writeText("newly_visible.txt", flags);
  std::string gone;
  gone.reserve(result.disappeared_labels.size() * 2);
  for (int l : result.disappeared_labels) gone += std::to_string(l) + '\n';
  out.writeText("disappeared_labels.txt", gone);
  out.writeText("disappeared_superquadrics.json",
                nd::cli::superquadricsJson(result.disappeared_superquadrics).dump(2) + "\n");
  // Disappearances need the current sweep's sensor origin.
  as.disappearances_checked = result.disappearances_checked;
  if (params.visibility.disappearances && !as.disappearances_checked)
    std::cerr << "novelty_detect: the current cloud's sensor origin is unknown (no VIEWPOINT): "
                 "disappearances not checked; give --current-origin X Y Z or --sensor-frame\n";
  if (result.up_source != "given")
    std::cerr << "novelty_detect: up (auto) = (" << result.up.x() << ", " << result.up.y() << ", "
              << result.up.z() << ") from "
              << (result.up_source == "plane" ? "a floor plane"
                                              : "no floor plane found: +z assumed")
              << "\n";
  for (const std::string& w : result.warnings) std::cerr << "novelty_detect: " << w << "\n";
  json report = nd::cli::reportJson(result, pipeline, ref_ms, det_ms, as);
  if (args.repeat > 1) {
    report["repeated"] = {{"detections", args.repeat},
                          {"first_timings_ms", first_timings},
                          {"detect_total_ms", runs_ms},
                          {"labels_identical", identical}};
  }
  out.writeText("report.json", report.dump(2) + "\n");

  // In the map frame, like segments and superquadrics, when the fine alignment moved the sweep.
  const nd::Cloud shown =
      result.alignment.applied ? nd::transformCloud(current, result.alignment.correction) : current;
  pcl::PointCloud<pcl::PointXYZRGB> coloured;
  coloured.resize(current.size());
  coloured.width = current.width;
  coloured.height = current.height;
  coloured.is_dense = current.is_dense;
  for (std::size_t i = 0; i < current.size(); ++i) {
    auto& p = coloured[i];
    p.x = shown[i].x, p.y = shown[i].y, p.z = shown[i].z;
    nd::cli::colour(result.labels[i], p.r, p.g, p.b);
  }
  const std::string segments = out.stagedPath("segments.pcd");
  if (coloured.empty() || pcl::io::savePCDFileBinary(segments, coloured) != 0) {
    // PCL refuses empty clouds: write a valid empty PCD by hand.
    if (!coloured.empty()) throw std::runtime_error("cannot write " + segments);
    out.writeText("segments.pcd",
                  "VERSION .7\nFIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\n"
                  "WIDTH 0\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 0\nDATA ascii\n");
  }
  out.commit();
  std::cout << "novelty_detect: " << result.segments.size() << " segment(s), "
            << result.superquadrics.size() << " superquadric(s), "
            << result.disappeared_segments.size() << " disappearance(s), detection " << det_ms
            << " ms\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return novelty_detection::runTool("novelty_detect", std::string(" (") + kUsage + ")", argc, argv,
                                    parseArgs, run);
}
