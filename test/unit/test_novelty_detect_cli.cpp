// The novelty_detect command line tool: its output files, and clean failures.
#include <gtest/gtest.h>

#include <unistd.h>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

#include "novelty_detection/alignment/alignment.h"
#include "novelty_detection/io/cloud_io.h"
#include "novelty_detection/sim/scene.h"
#include "temp_dir.h"

namespace fs = std::filesystem;
using namespace novelty_detection;

namespace {

struct CliRun {
  int code = 0;
  std::string err;
};

CliRun runCli(const std::string& args, const fs::path& dir) {
  const fs::path err_file = dir / "stderr.txt";
  const std::string cmd = std::string(NOVELTY_BIN_DIR) + "/novelty_detect " + args + " 2> " +
                          err_file.string() + " > /dev/null";
  CliRun r;
  r.code = std::system(cmd.c_str());
  std::ifstream in(err_file);
  std::stringstream ss;
  ss << in.rdbuf();
  r.err = ss.str();
  return r;
}

fs::path tempDir(const std::string& name) { return test_helpers::freshTempDir("cli", name); }

/// A simulated pair with one new object of `kind` saved as dir/ref.pcd and dir/cur.pcd; the
/// arguments naming them.
std::string savedPair(const fs::path& dir, unsigned seed, sim::NoveltyKind kind) {
  sim::SceneConfig c;
  c.seed = seed;
  c.novelty_kinds = {kind};
  const sim::ScenePair s = sim::generateScenePair(c);
  saveCloudAtomic((dir / "ref.pcd").string(), s.reference);
  saveCloudAtomic((dir / "cur.pcd").string(), s.current);
  return "--reference " + (dir / "ref.pcd").string() + " --current " + (dir / "cur.pcd").string();
}

/// A whole file as text.
std::string fileText(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace

TEST(NoveltyDetectCli, WritesTheContractFiles) {
  const fs::path dir = tempDir("ok");
  sim::SceneConfig c;
  c.seed = 3;
  c.novelty_kinds = {sim::NoveltyKind::kBox};
  const sim::ScenePair s = sim::generateScenePair(c);
  saveCloudAtomic((dir / "ref.pcd").string(), s.reference);
  saveCloudAtomic((dir / "cur.pcd").string(), s.current);
  const fs::path out = dir / "out" / "nested";  // created when missing
  const CliRun r = runCli("--reference " + (dir / "ref.pcd").string() + " --current " +
                              (dir / "cur.pcd").string() + " --out " + out.string(),
                          dir);
  ASSERT_EQ(r.code, 0) << r.err;

  std::ifstream labels(out / "labels.txt");
  std::size_t n = 0, novel = 0;
  for (int l; labels >> l; ++n) {
    EXPECT_GE(l, 0);
    novel += l > 0;
  }
  EXPECT_EQ(n, s.current.size());
  EXPECT_GT(novel, 0u);

  std::ifstream rep(out / "report.json");
  const auto report = nlohmann::json::parse(rep);
  for (const char* key : {"timings_ms", "point_counts", "gaussians", "emd_before", "emd_after",
                          "num_segments", "num_superquadrics"})
    EXPECT_TRUE(report.contains(key)) << key;
  EXPECT_GE(report["num_segments"].get<int>(), 1);
  EXPECT_GT(report["emd_before"].get<double>(), report["emd_after"].get<double>());
  EXPECT_EQ(report["point_counts"]["input"].get<std::size_t>(), s.current.size());

  std::ifstream sq(out / "superquadrics.json");
  const auto sqs = nlohmann::json::parse(sq);
  ASSERT_TRUE(sqs.is_array());
  EXPECT_EQ(sqs.size(), report["num_superquadrics"].get<std::size_t>());
  for (const auto& e : sqs) {
    for (const char* key :
         {"segment", "a", "epsilon", "position", "orientation", "points", "residual", "support"})
      EXPECT_TRUE(e.contains(key)) << key;
    const std::string support = e.value("support", "");
    EXPECT_TRUE(support == "points" || support == "floor_at_foot" || support == "hidden" ||
                support == "none")
        << support;
  }
  EXPECT_EQ(loadCloud((out / "segments.pcd").string()).size(), s.current.size());
  // Saved without VIEWPOINT: no disappearance is checked, every reference label is 0.
  EXPECT_FALSE(report["disappearances_checked"].get<bool>());
  std::ifstream gone(out / "disappeared_labels.txt");
  std::size_t n_ref = 0;
  for (int l; gone >> l; ++n_ref) EXPECT_EQ(l, 0);
  EXPECT_EQ(n_ref, s.reference.size());
  fs::remove_all(dir);
}

// The output directory holds one run's set: `complete` lists it, and a sweep that cannot be
// compared (500 m off the map) replaces it with a report only, exit code 3, never "no change".
TEST(NoveltyDetectCli, OutputIsOneSetAndNoOverlapIsExitThree) {
  const fs::path dir = tempDir("set");
  sim::SceneConfig c;
  c.seed = 4;
  c.novelty_kinds = {sim::NoveltyKind::kBox};
  const sim::ScenePair s = sim::generateScenePair(c);
  saveCloudAtomic((dir / "ref.pcd").string(), s.reference);
  saveCloudAtomic((dir / "cur.pcd").string(), s.current);
  Cloud far = s.current;
  for (PointT& p : far) p.x += 500.0f;
  saveCloudAtomic((dir / "far.pcd").string(), far);
  const fs::path out = dir / "out";
  const auto listing = [&] {
    std::ifstream in(out / "complete");
    std::vector<std::string> names;
    for (std::string n; std::getline(in, n);) names.push_back(n);
    std::sort(names.begin(), names.end());
    return names;
  };
  const auto entries = [&] {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(out)) names.push_back(e.path().filename());
    std::sort(names.begin(), names.end());
    return names;
  };
  CliRun r = runCli("--reference " + (dir / "ref.pcd").string() + " --current " +
                        (dir / "cur.pcd").string() + " --out " + out.string(),
                    dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const std::vector<std::string> full = {"disappeared_labels.txt",
                                         "disappeared_superquadrics.json",
                                         "labels.txt",
                                         "newly_visible.txt",
                                         "report.json",
                                         "segments.pcd",
                                         "superquadrics.json"};
  EXPECT_EQ(listing(), full);
  std::vector<std::string> with_marker = full;
  with_marker.push_back("complete");
  std::sort(with_marker.begin(), with_marker.end());
  EXPECT_EQ(entries(), with_marker);  // no staging or temporary file is left
  {
    std::ifstream rep(out / "report.json");
    const auto report = nlohmann::json::parse(rep);
    EXPECT_TRUE(report["compared"].get<bool>());
    EXPECT_GT(report["overlap"].get<double>(), 0.9);
  }

  r = runCli("--reference " + (dir / "ref.pcd").string() + " --current " +
                 (dir / "far.pcd").string() + " --out " + out.string(),
             dir);
  EXPECT_EQ(r.code >> 8, 3) << r.err;
  // One line says why (beside the note that the saved clouds carry no sensor origin).
  const std::size_t why = r.err.find("does not overlap the reference");
  ASSERT_NE(why, std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("does not overlap", why + 1), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 2) << r.err;
  std::ifstream rep(out / "report.json");
  const auto report = nlohmann::json::parse(rep);
  EXPECT_FALSE(report["compared"].get<bool>());
  EXPECT_LT(report["overlap"].get<double>(), 0.1);
  EXPECT_EQ(listing(), std::vector<std::string>{"report.json"});
  EXPECT_EQ(entries(), (std::vector<std::string>{"complete", "report.json"}));
  fs::remove_all(dir);
}

// Visibility outputs: a removed box (an inserted box read backwards), both clouds saved with
// their VIEWPOINT: disappeared_labels.txt per reference point marks the box, newly_visible.txt
// has a flag per current point, disappeared_superquadrics.json and the report agree.
TEST(NoveltyDetectCli, WritesDisappearancesAndNewlyVisible) {
  const fs::path dir = tempDir("gone");
  sim::SceneConfig c;
  c.seed = 3;
  c.novelty_kinds = {sim::NoveltyKind::kBox};
  const sim::ScenePair s = sim::generateScenePair(c);
  saveCloudAtomic((dir / "ref.pcd").string(), s.current, s.T_world_sensor_current);
  saveCloudAtomic((dir / "cur.pcd").string(), s.reference, s.T_world_sensor_reference);
  const fs::path out = dir / "out";
  const CliRun r = runCli("--reference " + (dir / "ref.pcd").string() + " --current " +
                              (dir / "cur.pcd").string() + " --out " + out.string(),
                          dir);
  ASSERT_EQ(r.code, 0) << r.err;
  std::ifstream gone(out / "disappeared_labels.txt");
  std::size_t n = 0, hit = 0, found = 0, box = 0;
  for (int l; gone >> l; ++n) {
    ASSERT_LT(n, s.current_labels.size());
    found += l > 0;
    hit += l > 0 && s.current_labels[n] > 0;
    box += s.current_labels[n] > 0;
  }
  EXPECT_EQ(n, s.current.size());  // one per reference point
  EXPECT_GE(hit, 0.8 * box) << found << " found";
  EXPECT_GE(hit, 0.95 * found);
  std::ifstream nv(out / "newly_visible.txt");
  std::size_t m = 0, flagged = 0;
  for (int f; nv >> f; ++m) {
    EXPECT_TRUE(f == 0 || f == 1);
    flagged += f;
  }
  EXPECT_EQ(m, s.reference.size());  // one per current point
  EXPECT_GT(flagged, 0u);
  std::ifstream rep(out / "report.json");
  const auto report = nlohmann::json::parse(rep);
  EXPECT_TRUE(report["disappearances_checked"].get<bool>());
  EXPECT_EQ(report["disappeared_points"].get<std::size_t>(), found);
  EXPECT_EQ(report["newly_visible_points"].get<std::size_t>(), flagged);
  EXPECT_EQ(report["num_disappeared_segments"].get<int>(), 1);
  std::ifstream sq(out / "disappeared_superquadrics.json");
  const auto sqs = nlohmann::json::parse(sq);
  ASSERT_TRUE(sqs.is_array());
  EXPECT_GE(sqs.size(), 1u);
  EXPECT_EQ(sqs.size(), report["num_disappeared_superquadrics"].get<std::size_t>());
  fs::remove_all(dir);
}

TEST(NoveltyDetectCli, FailsCleanly) {
  const fs::path dir = tempDir("bad");
  // Missing input file: non-zero exit, one line naming the problem.
  CliRun r = runCli("--reference " + (dir / "missing.pcd").string() + " --current " +
                        (dir / "missing.pcd").string() + " --out " + (dir / "o").string(),
                    dir);
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.err.find("missing.pcd"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  // Bad arguments.
  r = runCli("--reference", dir);
  EXPECT_NE(r.code, 0);
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  r = runCli("--bogus x", dir);
  EXPECT_NE(r.code, 0);
  // Invalid configuration.
  Cloud tiny;
  for (int i = 0; i < 10; ++i) tiny.push_back(PointT(i, 0, 1));
  saveCloudAtomic((dir / "t.pcd").string(), tiny);
  std::ofstream(dir / "bad.yaml") << "gmm:\n  max_components: -3\n";
  r = runCli("--reference " + (dir / "t.pcd").string() + " --current " + (dir / "t.pcd").string() +
                 " --out " + (dir / "o").string() + " --config " + (dir / "bad.yaml").string(),
             dir);
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.err.find("max_components"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  fs::remove_all(dir);
}

TEST(NoveltyDetectCli, ReportsTheFineAlignment) {
  const fs::path dir = tempDir("align");
  sim::SceneConfig c;
  c.seed = 3;
  c.novelty_kinds = {sim::NoveltyKind::kBox};
  c.laser.noise_variance_m2 = 1e-4;
  const sim::ScenePair s = sim::generateScenePair(c);
  Eigen::Isometry3d E = Eigen::Isometry3d::Identity();
  E.translation() = Eigen::Vector3d(0.0, 0.02, 0.0);  // a 2 cm localisation error
  saveCloudAtomic((dir / "ref.pcd").string(), s.reference);
  saveCloudAtomic((dir / "cur.pcd").string(), transformCloud(s.current, E));
  std::ofstream((dir / "align.yaml").string()) << "alignment:\n  enabled: true\n";
  const fs::path out = dir / "out";
  const CliRun r = runCli("--reference " + (dir / "ref.pcd").string() + " --current " +
                              (dir / "cur.pcd").string() + " --out " + out.string() + " --config " +
                              (dir / "align.yaml").string(),
                          dir);
  ASSERT_EQ(r.code, 0) << r.err;
  std::ifstream rep(out / "report.json");
  const auto report = nlohmann::json::parse(rep);
  ASSERT_TRUE(report.contains("alignment"));
  const auto& a = report["alignment"];
  EXPECT_TRUE(a["applied"].get<bool>()) << a["status"];
  EXPECT_NEAR(a["translation_m"].get<double>(), 0.02, 0.005);
  EXPECT_EQ(a["translation"].size(), 3u);
  EXPECT_EQ(a["quaternion"].size(), 4u);
  EXPECT_TRUE(report["timings_ms"].contains("alignment"));
  fs::remove_all(dir);
}

// Origins given on the command line replace a missing VIEWPOINT: the clouds saved without
// one get the visibility rules and disappearances back, the report says where each origin
// came from, up and the floor; without them, stderr names the flag that turns them on.
TEST(NoveltyDetectCli, OriginAndUpFlags) {
  const fs::path dir = tempDir("origin");
  sim::SceneConfig c;
  c.seed = 3;
  c.novelty_kinds = {sim::NoveltyKind::kBox};
  const sim::ScenePair s = sim::generateScenePair(c);
  saveCloudAtomic((dir / "ref.pcd").string(), s.reference);  // no VIEWPOINT
  saveCloudAtomic((dir / "cur.pcd").string(), s.current);
  const std::string files = "--reference " + (dir / "ref.pcd").string() + " --current " +
                            (dir / "cur.pcd").string() + " --out ";
  const CliRun plain = runCli(files + (dir / "plain").string(), dir);
  ASSERT_EQ(plain.code, 0) << plain.err;
  EXPECT_NE(plain.err.find("--reference-origin"), std::string::npos) << plain.err;
  EXPECT_NE(plain.err.find("--current-origin"), std::string::npos) << plain.err;
  auto origin = [](const Eigen::Isometry3d& T) {
    const Eigen::Vector3d t = T.translation();
    return std::to_string(t.x()) + " " + std::to_string(t.y()) + " " + std::to_string(t.z());
  };
  const CliRun given = runCli(files + (dir / "given").string() + " --reference-origin " +
                                  origin(s.T_world_sensor_reference) + " --current-origin " +
                                  origin(s.T_world_sensor_current) + " --up 0 0 2",
                              dir);
  ASSERT_EQ(given.code, 0) << given.err;
  std::ifstream a(dir / "plain" / "report.json"), b(dir / "given" / "report.json");
  const auto ra = nlohmann::json::parse(a), rb = nlohmann::json::parse(b);
  EXPECT_FALSE(ra["visibility_checked"].get<bool>());
  EXPECT_FALSE(ra["disappearances_checked"].get<bool>());
  EXPECT_TRUE(ra["sensor_origins"]["reference"]["position"].is_null());
  EXPECT_EQ(ra["sensor_origins"]["reference"]["from"], "unknown");
  EXPECT_TRUE(rb["visibility_checked"].get<bool>());
  EXPECT_TRUE(rb["disappearances_checked"].get<bool>());
  EXPECT_EQ(rb["sensor_origins"]["current"]["from"], "given");
  EXPECT_NEAR(rb["sensor_origins"]["current"]["position"][0].get<double>(),
              s.T_world_sensor_current.translation().x(), 1e-4);
  EXPECT_NEAR(rb["up"][2].get<double>(), 1.0, 1e-9);  // normalised
  ASSERT_TRUE(rb["floor"].is_array());
  EXPECT_GT(rb["floor"][2].get<double>(), 0.99);  // the simulator's floor, z = 0
  EXPECT_NEAR(rb["floor"][3].get<double>(), 0.0, 0.03);
  // Bad values are refused as arguments.
  EXPECT_EQ(runCli(files + (dir / "x").string() + " --current-origin 1 2", dir).code >> 8, 2);
  EXPECT_EQ(runCli(files + (dir / "x").string() + " --up 0 0 0", dir).code >> 8, 2);
  EXPECT_EQ(runCli(files + (dir / "x").string() + " --up nan 0 1", dir).code >> 8, 2);
  EXPECT_EQ(runCli("--help", dir).code, 0);
  // The same origins from a configuration file; a flag overrides the file.
  {
    std::ofstream yaml(dir / "origins.yaml");
    yaml << "preprocess:\n  reference_origin: \"" << origin(s.T_world_sensor_reference)
         << "\"\n  current_origin: \"" << origin(s.T_world_sensor_current) << "\"\n";
  }
  const CliRun configured =
      runCli(files + (dir / "configured").string() + " --config " +
                 (dir / "origins.yaml").string() + " --current-origin 0 0 0.5",
             dir);
  ASSERT_EQ(configured.code, 0) << configured.err;
  std::ifstream cfile(dir / "configured" / "report.json");
  const auto rc = nlohmann::json::parse(cfile);
  EXPECT_TRUE(rc["visibility_checked"].get<bool>());
  EXPECT_EQ(rc["sensor_origins"]["reference"]["from"], "given");
  EXPECT_NEAR(rc["sensor_origins"]["reference"]["position"][1].get<double>(),
              s.T_world_sensor_reference.translation().y(), 1e-4);
  EXPECT_NEAR(rc["sensor_origins"]["current"]["position"][2].get<double>(), 0.5, 1e-6);
  {
    std::ofstream yaml(dir / "bad.yaml");
    yaml << "preprocess:\n  reference_origin: \"1 2\"\n";
  }
  const CliRun bad =
      runCli(files + (dir / "x").string() + " --config " + (dir / "bad.yaml").string(), dir);
  EXPECT_EQ(bad.code >> 8, 1);
  EXPECT_NE(bad.err.find("preprocess/reference_origin"), std::string::npos) << bad.err;
  fs::remove_all(dir);
}

// --reference-cache: the first run builds and stores the map's model, the next one reads it
// back (report.json says which) and writes the same files; a damaged cache file is named on
// stderr and replaced, and the run still succeeds.
TEST(NoveltyDetectCli, ReferenceCache) {
  const fs::path dir = tempDir("cache");
  const std::string args = savedPair(dir, 9, sim::NoveltyKind::kBox) + " --reference-cache " +
                           (dir / "models").string() + " --out ";
  auto report = [&](const std::string& run) {
    return nlohmann::json::parse(fileText(dir / run / "report.json"));
  };
  auto file = [&](const std::string& run, const char* name) { return fileText(dir / run / name); };
  ASSERT_EQ(runCli(args + (dir / "first").string(), dir).code, 0);
  ASSERT_EQ(runCli(args + (dir / "second").string(), dir).code, 0);
  const auto first = report("first"), second = report("second");
  EXPECT_EQ(first["reference_cache"]["state"], "written");
  EXPECT_EQ(second["reference_cache"]["state"], "hit");
  EXPECT_EQ(first["reference_cache"]["key"], second["reference_cache"]["key"]);
  for (const char* name : {"labels.txt", "superquadrics.json", "disappeared_labels.txt"})
    EXPECT_EQ(file("first", name), file("second", name)) << name;
  EXPECT_NE(file("first", "labels.txt").find('1'), std::string::npos);  // something found
  const fs::path model =
      dir / "models" / (first["reference_cache"]["key"].get<std::string>() + ".refmodel");
  ASSERT_TRUE(fs::exists(model));
  fs::resize_file(model, fs::file_size(model) / 2);
  const CliRun damaged = runCli(args + (dir / "third").string(), dir);
  ASSERT_EQ(damaged.code, 0) << damaged.err;
  EXPECT_NE(damaged.err.find(model.string()), std::string::npos) << damaged.err;
  EXPECT_EQ(report("third")["reference_cache"]["state"], "replaced");
  EXPECT_EQ(file("first", "labels.txt"), file("third", "labels.txt"));
  // Without the flag the cache is off.
  ASSERT_EQ(runCli("--reference " + (dir / "ref.pcd").string() + " --current " +
                       (dir / "cur.pcd").string() + " --out " + (dir / "plain").string(),
                   dir)
                .code,
            0);
  EXPECT_EQ(report("plain")["reference_cache"]["state"], "off");
  EXPECT_EQ(runCli(args, dir).code >> 8, 2);  // --out without its value
  fs::remove_all(dir);
}

// --repeat N detects the sweep N times in one process: the files are those of one detection,
// report.json's timings are the last detection's and `repeated` holds the first's stage times
// and every total; a count that is not a whole number from 1 to 1000 is a bad argument.
TEST(NoveltyDetectCli, RepeatDetectsInOneProcess) {
  const fs::path dir = tempDir("repeat");
  const std::string args = savedPair(dir, 4, sim::NoveltyKind::kCylinder) + " --out ";
  auto file = [&](const std::string& run, const char* name) { return fileText(dir / run / name); };
  ASSERT_EQ(runCli(args + (dir / "once").string(), dir).code, 0);
  const CliRun r = runCli(args + (dir / "thrice").string() + " --repeat 3", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  for (const char* name : {"labels.txt", "superquadrics.json", "disappeared_labels.txt"})
    EXPECT_EQ(file("once", name), file("thrice", name)) << name;
  EXPECT_NE(file("once", "labels.txt").find('1'), std::string::npos);  // something found
  const auto report = nlohmann::json::parse(fileText(dir / "thrice" / "report.json"));
  ASSERT_TRUE(report.contains("repeated"));
  const auto& repeated = report["repeated"];
  EXPECT_EQ(repeated["detections"].get<int>(), 3);
  EXPECT_TRUE(repeated["labels_identical"].get<bool>());
  const auto totals = repeated["detect_total_ms"].get<std::vector<double>>();
  ASSERT_EQ(totals.size(), 3u);
  EXPECT_EQ(report["timings_ms"]["detect_total"].get<double>(), totals.back());
  EXPECT_EQ(repeated["first_timings_ms"]["detect_total"].get<double>(), totals.front());
  for (const auto& [stage, ms] : report["timings_ms"].items()) {
    if (stage == "reference_model") continue;  // once per process, not per detection
    EXPECT_TRUE(repeated["first_timings_ms"].contains(stage)) << stage;
    EXPECT_GE(ms.get<double>(), 0.0) << stage;
  }
  EXPECT_FALSE(nlohmann::json::parse(fileText(dir / "once" / "report.json")).contains("repeated"));
  for (const char* bad : {"0", "1001", "2x", "-1", ""}) {
    const CliRun b = runCli(args + (dir / "bad").string() + " --repeat '" + bad + "'", dir);
    EXPECT_EQ(b.code >> 8, 2) << bad;
    EXPECT_NE(b.err.find("--repeat"), std::string::npos) << b.err;
  }
  fs::remove_all(dir);
}
