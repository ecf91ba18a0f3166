// simulate_scans: writes simulated scene pairs (reference and current sweep of a tilting
// Hokuyo in a corridor or office, with exact ground truth) as PCD, labels, JSON and a rosbag.
//
//   simulate_scans --out DIR [--seed S] [--layout corridor|office] [--lines N]
//                  [--noise-var V] [--offset DX DY DYAW_DEG] [--novelties K]
//                  [--loc-error X Y Z ROLL_DEG PITCH_DEG YAW_DEG]
//                  [--kinds box,person,...] [--suite [N]] [--suite-kind default|viewpoint]
//                  [--no-bag]
//   simulate_scans --out DIR --route [N_SWEEPS] [--seed S] [--layout corridor|office]
//
// --route: a patrol route (sim/route.h) of N_SWEEPS reference sweeps (default 10) as
// DIR/route.bag (every sweep's lines, tf and sweep, 1 s apart), the current sequence as
// DIR/cur_K.pcd with DIR/gt_labels_K.txt (1: the object that stays, 2: the walking person),
// and DIR/route.json.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "novelty_detection/io/cloud_io.h"
#include "novelty_detection/sim/route.h"
#include "novelty_detection/sim/scene.h"
#include "novelty_detection/sim/scene_json.h"
#include "sweep_bag.h"
#include "tool_main.h"

namespace fs = std::filesystem;
using namespace novelty_detection;
using namespace novelty_detection::sweep_bag;

namespace {

const char* kUsage =
    "usage: simulate_scans --out DIR [--seed S] [--layout corridor|office] [--lines N]\n"
    "                      [--noise-var V] [--offset DX DY DYAW_DEG] [--novelties K]\n"
    "                      [--loc-error X Y Z ROLL_DEG PITCH_DEG YAW_DEG]\n"
    "                      [--kinds box,cylinder,sphere,superellipsoid,person,moved_object,door,\n"
    "                               removed_object]\n"
    "                      [--suite [N]] [--suite-kind default|viewpoint] [--no-bag]\n"
    "       simulate_scans --out DIR --route [N_SWEEPS] [--seed S] [--layout corridor|office]\n";

struct Options {
  std::string out;
  std::uint64_t seed = 1;
  sim::SceneConfig scene;
  bool suite = false;
  int suite_size = 30;
  std::string suite_kind = "default";
  bool suite_kind_set = false;
  bool bag = true;
  int route_sweeps = 0;  ///< > 0: write a patrol route of this many sweeps
  bool lines_set = false, noise_set = false, scene_set = false;
};

double toDouble(const std::string& flag, const std::string& s) {
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(s, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != s.size() || !std::isfinite(v))
    throw std::invalid_argument(flag + " expects a number, got '" + s + "'");
  return v;
}

long toInt(const std::string& flag, const std::string& s) {
  std::size_t used = 0;
  long v = 0;
  try {
    v = std::stol(s, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != s.size()) throw std::invalid_argument(flag + " expects an integer, got '" + s + "'");
  return v;
}

Options parse(int argc, char** argv) {
  Options o;
  std::vector<std::string> a(argv + 1, argv + argc);
  auto value = [&](std::size_t& i) -> const std::string& {
    if (i + 1 >= a.size() || a[i + 1].rfind("--", 0) == 0)
      throw std::invalid_argument(a[i] + " needs a value");
    return a[++i];
  };
  for (std::size_t i = 0; i < a.size(); ++i) {
    const std::string& f = a[i];
    if (f == "--out") {
      o.out = value(i);
    } else if (f == "--seed") {
      const long s = toInt(f, value(i));
      if (s < 0) throw std::invalid_argument("--seed must be >= 0");
      o.seed = static_cast<std::uint64_t>(s);
    } else if (f == "--layout") {
      o.scene.layout = sim::layoutFromString(value(i));
      o.scene_set = true;
    } else if (f == "--lines") {
      o.scene.laser.lines = static_cast<int>(toInt(f, value(i)));
      o.lines_set = true;
    } else if (f == "--noise-var") {
      o.scene.laser.noise_variance_m2 = toDouble(f, value(i));
      o.noise_set = true;
    } else if (f == "--offset") {
      if (i + 3 >= a.size()) throw std::invalid_argument("--offset needs DX DY DYAW_DEG");
      const double dx = toDouble(f, a[i + 1]), dy = toDouble(f, a[i + 2]);
      const double dyaw = toDouble(f, a[i + 3]) * kDeg;
      o.scene.pose_offset = Eigen::Vector3d(dx, dy, dyaw);
      i += 3;
      o.scene_set = true;
    } else if (f == "--loc-error") {
      if (i + 6 >= a.size())
        throw std::invalid_argument("--loc-error needs X Y Z ROLL_DEG PITCH_DEG YAW_DEG");
      for (int k = 0; k < 6; ++k)
        o.scene.localisation_error(k) = toDouble(f, a[i + 1 + k]) * (k < 3 ? 1.0 : kDeg);
      i += 6;
      o.scene_set = true;
    } else if (f == "--suite-kind") {
      o.suite_kind = value(i);
      if (o.suite_kind != "default" && o.suite_kind != "viewpoint")
        throw std::invalid_argument("--suite-kind must be default or viewpoint, got '" +
                                    o.suite_kind + "'");
      o.suite_kind_set = true;
    } else if (f == "--novelties") {
      o.scene.novelty_count = static_cast<int>(toInt(f, value(i)));
      o.scene_set = true;
    } else if (f == "--kinds") {
      std::stringstream ss(value(i));
      std::string name;
      while (std::getline(ss, name, ','))
        o.scene.novelty_kinds.push_back(sim::noveltyKindFromString(name));
      o.scene_set = true;
    } else if (f == "--suite") {
      o.suite = true;
      if (i + 1 < a.size() && a[i + 1].rfind("--", 0) != 0) {
        const long n = toInt(f, a[++i]);
        if (n < 1 || n > 1000) throw std::invalid_argument("--suite N must lie in [1, 1000]");
        o.suite_size = static_cast<int>(n);
      }
    } else if (f == "--route") {
      o.route_sweeps = 10;
      if (i + 1 < a.size() && a[i + 1].rfind("--", 0) != 0) {
        const long n = toInt(f, a[++i]);
        if (n < 2 || n > 40) throw std::invalid_argument("--route N_SWEEPS must lie in [2, 40]");
        o.route_sweeps = static_cast<int>(n);
      }
    } else if (f == "--no-bag") {
      o.bag = false;
    } else if (f == "--help" || f == "-h") {
      std::cout << kUsage;
      std::exit(0);
    } else {
      throw std::invalid_argument("unknown argument '" + f + "'");
    }
  }
  if (o.out.empty()) throw std::invalid_argument("--out DIR is required");
  if (o.suite_kind_set && !o.suite) throw std::invalid_argument("--suite-kind needs --suite");
  if (o.suite && o.scene_set)
    throw std::invalid_argument(
        "--layout, --offset, --loc-error, --novelties and --kinds choose one scene; a --suite "
        "varies them");
  if (o.route_sweeps > 0 &&
      (o.suite || o.lines_set || o.noise_set || !o.bag ||
       o.scene.pose_offset != Eigen::Vector3d::Zero() || !o.scene.localisation_error.isZero() ||
       !o.scene.novelty_kinds.empty()))
    throw std::invalid_argument("--route takes only --seed and --layout");
  o.scene.seed = o.seed;
  o.scene.validate();
  return o;
}

void writeTextAtomic(const fs::path& path, const std::string& text) {
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream f(tmp);
    f << text;
    if (!f.flush()) throw std::runtime_error("cannot write " + tmp.string());
  }
  fs::rename(tmp, path);
}

// ---------------------------------------------------------------------------------------
void writeBag(const fs::path& path, const sim::ScenePair& s) {
  const fs::path tmp = path.string() + ".tmp";
  const double t0 = 1000.0;  // fixed, so bags are reproducible
  const double dt = std::min(0.025, 0.9 / std::max(1, s.config.laser.lines));
  {
    rosbag::Bag bag;
    bag.open(tmp.string(), rosbag::bagmode::Write);
    writeSweep(bag, s.config.laser, s.reference_lines, basePose(s.base_pose_reference), s.reference,
               t0, dt);
    writeSweep(bag, s.config.laser, s.current_lines, s.T_error * basePose(s.base_pose_current),
               s.current, t0 + 1.0, dt);
    bag.close();
  }
  fs::rename(tmp, path);
}

// ---------------------------------------------------------------------------------------

std::string kindsText(const sim::ScenePair& s) {
  std::string t;
  for (const auto& o : s.objects) t += (t.empty() ? "" : "+") + sim::toString(o.kind);
  return t.empty() ? "none" : t;
}

nlohmann::json writeScene(const fs::path& dir, const sim::SceneConfig& config, bool bag) {
  fs::create_directories(dir);
  const sim::ScenePair s = sim::generateScenePair(config);
  saveCloudAtomic((dir / "ref.pcd").string(), s.reference, s.T_world_sensor_reference);
  // The current sweep as the robot reports it: cloud and VIEWPOINT in the erroneous frame.
  saveCloudAtomic((dir / "cur.pcd").string(), s.current, s.T_error * s.T_world_sensor_current);
  auto lines = [](const auto& values) {
    std::string text;
    text.reserve(3 * values.size());
    for (const auto v : values) text += std::to_string(static_cast<int>(v)) + "\n";
    return text;
  };
  writeTextAtomic(dir / "gt_labels.txt", lines(s.current_labels));
  writeTextAtomic(dir / "gt_disappeared_labels.txt", lines(s.reference_labels));
  writeTextAtomic(dir / "gt_newly_visible.txt", lines(s.current_newly_visible));
  const nlohmann::json j = sim::sceneToJson(s);
  writeTextAtomic(dir / "scene.json", j.dump(2) + "\n");
  if (bag) writeBag(dir / "scans.bag", s);
  std::size_t novel = 0, disappeared = 0, newly_visible = 0;
  for (int l : s.current_labels) novel += l > 0;
  for (int l : s.reference_labels) disappeared += l > 0;
  for (auto v : s.current_newly_visible) newly_visible += v != 0;
  if (s.objects.size() < config.novelty_kinds.size() ||
      (config.novelty_kinds.empty() && static_cast<int>(s.objects.size()) < config.novelty_count))
    std::cerr << "simulate_scans: warning: " << dir.string()
              << ": some novelties found no visible place and were left out\n";
  return {{"dir", dir.filename().string()},
          {"seed", config.seed},
          {"layout", sim::toString(config.layout)},
          {"group", sim::sceneGroup(config)},
          {"objects", kindsText(s)},
          {"object_count", s.objects.size()},
          {"reference_points", s.reference.size()},
          {"current_points", s.current.size()},
          {"novel_points", novel},
          {"disappeared_points", disappeared},
          {"newly_visible_points", newly_visible},
          {"pose_offset",
           {{"x_m", config.pose_offset.x()},
            {"y_m", config.pose_offset.y()},
            {"yaw_deg", config.pose_offset.z() / kDeg}}},
          {"localisation_error",
           {{"x_m", config.localisation_error(0)},
            {"y_m", config.localisation_error(1)},
            {"z_m", config.localisation_error(2)},
            {"roll_deg", config.localisation_error(3) / kDeg},
            {"pitch_deg", config.localisation_error(4) / kDeg},
            {"yaw_deg", config.localisation_error(5) / kDeg}}}};
}

void printScene(const std::string& prefix, const nlohmann::json& j, double seconds) {
  std::printf(
      "%s%s: %s, %s, %s, %d ref / %d cur points, %d novel, %d disappeared, %d newly visible, "
      "%.2f s\n",
      prefix.c_str(), j["dir"].get<std::string>().c_str(), j["layout"].get<std::string>().c_str(),
      j["group"].get<std::string>().c_str(), j["objects"].get<std::string>().c_str(),
      j["reference_points"].get<int>(), j["current_points"].get<int>(),
      j["novel_points"].get<int>(), j["disappeared_points"].get<int>(),
      j["newly_visible_points"].get<int>(), seconds);
  std::fflush(stdout);
}

std::string labelText(const std::vector<int>& labels) {
  std::string text;
  for (int l : labels) text += std::to_string(l) + "\n";
  return text;
}

int writeRoute(const Options& opt) {
  const fs::path out(opt.out);
  fs::create_directories(out);
  sim::RouteConfig c;
  c.seed = opt.seed;
  c.layout = opt.scene.layout;
  c.reference_sweeps = opt.route_sweeps;
  const sim::RouteScene r = sim::generateRoute(c);
  const fs::path tmp = (out / "route.bag").string() + ".tmp";
  const double dt = std::min(0.025, 0.9 / std::max(1, c.laser.lines));
  {
    rosbag::Bag bag;
    bag.open(tmp.string(), rosbag::bagmode::Write);
    for (std::size_t k = 0; k < r.reference.size(); ++k) {
      const sim::RouteSweep& s = r.reference[k];
      writeSweep(bag, c.laser, s.lines, basePose(s.base_pose), s.cloud, 1000.0 + k, dt);
    }
    bag.close();
  }
  fs::rename(tmp, out / "route.bag");
  nlohmann::json sequence = nlohmann::json::array();
  for (std::size_t k = 0; k < r.sequence.size(); ++k) {
    const sim::RouteSweep& s = r.sequence[k];
    const std::string n = std::to_string(k);
    saveCloudAtomic((out / ("cur_" + n + ".pcd")).string(), s.cloud, s.T_world_sensor);
    writeTextAtomic(out / ("gt_labels_" + n + ".txt"), labelText(s.labels));
    sequence.push_back({{"points", s.cloud.size()},
                        {"object_points", std::count(s.labels.begin(), s.labels.end(), 1)},
                        {"person_points", std::count(s.labels.begin(), s.labels.end(), 2)}});
  }
  const nlohmann::json j = {{"seed", c.seed},
                            {"layout", sim::toString(c.layout)},
                            {"reference_sweeps", r.reference.size()},
                            {"object", sim::toString(r.object.kind)},
                            {"sequence", sequence}};
  writeTextAtomic(out / "route.json", j.dump(2) + "\n");
  std::printf("wrote %s/{route.bag,cur_0..%zu.pcd,gt_labels_0..%zu.txt,route.json}: %zu sweeps\n",
              out.c_str(), r.sequence.size() - 1, r.sequence.size() - 1, r.reference.size());
  return 0;
}

int run(const Options& opt) {
  using Clock = std::chrono::steady_clock;
  const fs::path out(opt.out);
  if (opt.route_sweeps > 0) return writeRoute(opt);
  if (!opt.suite) {
    const auto t = Clock::now();
    const nlohmann::json j = writeScene(out, opt.scene, opt.bag);
    printScene("", j, std::chrono::duration<double>(Clock::now() - t).count());
    std::printf(
        "wrote %s/{ref.pcd,cur.pcd,gt_labels.txt,gt_disappeared_labels.txt,"
        "gt_newly_visible.txt,scene.json%s}\n",
        out.c_str(), opt.bag ? ",scans.bag" : "");
    return 0;
  }
  fs::create_directories(out);
  nlohmann::json scenes = nlohmann::json::array();
  const auto start = Clock::now();
  for (int i = 0; i < opt.suite_size; ++i) {
    sim::SceneConfig c = opt.suite_kind == "viewpoint" ? sim::viewpointSceneConfig(i, opt.seed)
                                                       : sim::suiteSceneConfig(i, opt.seed);
    if (opt.lines_set) c.laser.lines = opt.scene.laser.lines;
    if (opt.noise_set) c.laser.noise_variance_m2 = opt.scene.laser.noise_variance_m2;
    char name[32];
    std::snprintf(name, sizeof(name), "scene_%03d", i);
    const auto t = Clock::now();
    scenes.push_back(writeScene(out / name, c, opt.bag));
    char prefix[32];
    std::snprintf(prefix, sizeof(prefix), "[%d/%d] ", i + 1, opt.suite_size);
    printScene(prefix, scenes.back(), std::chrono::duration<double>(Clock::now() - t).count());
  }
  const nlohmann::json suite = {{"suite_seed", opt.seed},
                                {"size", opt.suite_size},
                                {"kind", opt.suite_kind},
                                {"bag", opt.bag},
                                {"scenes", scenes}};
  writeTextAtomic(out / "suite.json", suite.dump(2) + "\n");
  std::printf("wrote %d scenes and suite.json to %s in %.1f s\n", opt.suite_size, out.c_str(),
              std::chrono::duration<double>(Clock::now() - start).count());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return novelty_detection::runTool("simulate_scans", " (see --help)", argc, argv, parse, run);
}
