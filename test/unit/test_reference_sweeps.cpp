// A reference made of several sweeps, each with its viewpoint (a route map): what any of
// them saw through is free space; the directory format on disk; the command line with it.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "novelty_detection/io/reference_sweeps.h"
#include "novelty_detection/pipeline.h"
#include "novelty_detection/visibility/visibility.h"
#include "route_scene.h"
#include "temp_dir.h"

namespace fs = std::filesystem;
using namespace novelty_detection;
using namespace novelty_detection::route_scene;

namespace {

RangeImage imageOf(const Cloud& cloud, const Eigen::Vector3d& origin) {
  RangeImage image;
  image.build(cloud, {}, origin.cast<float>(), RangeImage::Config{});
  return image;
}

/// Sweeps A and B merged, with their views.
ReferenceMap routeMap() {
  ReferenceMap map;
  const Cloud a = sweepFrom(kA, {kPillar}, false, 1).cloud;
  const Cloud b = sweepFrom(kB, {kPillar}, true, 2).cloud;
  map.cloud = a;
  map.cloud += b;
  map.views.origins = {kA.cast<float>(), kB.cast<float>()};
  map.views.sweep.assign(a.size(), 0);
  map.views.sweep.insert(map.views.sweep.end(), b.size(), 1);
  return map;
}

CloudFile sweepFile(const Cloud& cloud, const Eigen::Vector3d& origin) {
  CloudFile f;
  f.cloud = cloud;
  f.T_frame_sensor.translation() = origin;
  return f;
}

fs::path tempDir(const std::string& name) { return test_helpers::freshTempDir("sweeps", name); }

}  // namespace

TEST(ReferenceVisibility, FreeWhenAnySweepSawThrough) {
  const RangeImage a = imageOf(sweepFrom(kA, {kPillar}, false, 1).cloud, kA);
  const RangeImage b = imageOf(sweepFrom(kB, {kPillar}, true, 2).cloud, kB);
  const Eigen::Vector3f behind_pillar(4.6f, 0.0f, 0.4f), past_end(13.0f, 0.0f, 1.0f),
      floor_near_a(1.5f, 0.0f, 0.0f);
  const double margin = 0.05;
  ASSERT_EQ(a.classify(behind_pillar, margin), Visibility::kOccluded);
  ASSERT_EQ(b.classify(behind_pillar, margin), Visibility::kFree);
  ReferenceVisibility both;
  EXPECT_TRUE(both.empty());
  both.add(a);
  both.add(RangeImage());  // an empty image is not a view
  both.add(b);
  EXPECT_EQ(both.views(), 2u);
  EXPECT_EQ(both.classify(behind_pillar, margin), Visibility::kFree);
  // Behind the end wall for A and behind B's back: occluded, not unknown.
  ASSERT_EQ(b.classify(past_end, margin), Visibility::kUnknown);
  EXPECT_EQ(both.classify(past_end, margin), Visibility::kOccluded);
  // On the floor in front of A, which the pillar hides from B.
  ASSERT_EQ(b.classify(floor_near_a, margin), Visibility::kOccluded);
  EXPECT_EQ(both.classify(floor_near_a, margin), Visibility::kOccupied);
  ReferenceVisibility only_a;
  only_a.add(a);
  EXPECT_EQ(only_a.classify(behind_pillar, margin), Visibility::kOccluded);
}

TEST(ReferenceSweeps, AnObjectInOneSweepsShadowIsFoundThroughTheOther) {
  const ReferenceMap map = routeMap();
  const synthetic::Scene current = sweepFrom(kC, {kPillar, kObject}, true, 3);
  Cloud cur = current.cloud;
  setSensorOrigin(cur, kC.cast<float>());
  Pipeline pipeline{Params()};
  pipeline.setReference(map.cloud, map.views);
  EXPECT_EQ(pipeline.referenceViewpoints(), 2u);
  const Result r = pipeline.detect(cur);
  std::size_t truth = 0;
  for (int l : current.label) truth += l == synthetic::kObject + 1;
  ASSERT_GT(truth, 200u);
  double best_iou = 0.0;
  std::size_t false_points = 0;
  for (const Segment& s : r.segments) {
    std::size_t hit = 0;
    for (int i : s.indices) hit += current.label[i] == synthetic::kObject + 1;
    best_iou = std::max(best_iou, static_cast<double>(hit) / (s.indices.size() + truth - hit));
    false_points += s.indices.size() - hit;
  }
  EXPECT_GE(best_iou, 0.8);
  EXPECT_LE(false_points, cur.size() / 100);

  // The same sweep without the object: nothing is new.
  Cloud empty = sweepFrom(kC, {kPillar}, true, 4).cloud;
  setSensorOrigin(empty, kC.cast<float>());
  EXPECT_TRUE(pipeline.detect(empty).segments.empty());
}

TEST(ReferenceSweeps, ViewsThatDoNotMatchTheCloudAreRefused) {
  ReferenceMap map = routeMap();
  Pipeline pipeline{Params()};
  ReferenceViews short_views = map.views;
  short_views.sweep.pop_back();
  EXPECT_THROW(pipeline.setReference(map.cloud, short_views), std::invalid_argument);
  ReferenceViews bad_index = map.views;
  bad_index.sweep[0] = 7;
  EXPECT_THROW(pipeline.setReference(map.cloud, bad_index), std::invalid_argument);
  ReferenceViews nan_origin = map.views;
  nan_origin.origins[1].x() = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(pipeline.setReference(map.cloud, nan_origin), std::invalid_argument);
  EXPECT_FALSE(pipeline.hasReference());
}

TEST(ReferenceSweeps, DirectoryRoundTrip) {
  const fs::path dir = tempDir("roundtrip");
  const Cloud a = sweepFrom(kA, {kPillar}, false, 1).cloud;
  const Cloud b = sweepFrom(kB, {kPillar}, true, 2).cloud;
  const fs::path ref = dir / "route";
  // The first sweep at the map's origin: a stated pose, not an unknown one.
  saveReferenceSweeps(ref.string(), {sweepFile(a, Eigen::Vector3d::Zero()), sweepFile(b, kB)});
  std::ofstream(ref / "notes.txt") << "ignored";
  const ReferenceMap map = loadReference(ref.string());
  ASSERT_EQ(map.files.size(), 2u);
  EXPECT_EQ(fs::path(map.files[0]).filename(), "sweep_0000.pcd");
  ASSERT_EQ(map.cloud.size(), a.size() + b.size());
  ASSERT_EQ(map.views.origins.size(), 2u);
  EXPECT_TRUE(map.views.origins[0].isZero());
  EXPECT_TRUE(map.views.origins[1].isApprox(kB.cast<float>()));
  ASSERT_EQ(map.views.sweep.size(), map.cloud.size());
  EXPECT_EQ(map.views.sweep[a.size() - 1], 0u);
  EXPECT_EQ(map.views.sweep[a.size()], 1u);
  EXPECT_EQ(map.cloud[a.size()].x, b[0].x);
  EXPECT_EQ(map.cloud[5].y, a[5].y);

  // Total points are bounded across the sweeps.
  LoadLimits limits;
  limits.max_points = a.size() + b.size() - 1;
  try {
    loadReference(ref.string(), limits);
    ADD_FAILURE() << "a reference over the limit was loaded";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("preprocess/max_points"), std::string::npos) << e.what();
  }
  // A directory holding other files is not replaced; one of our sweeps only is.
  EXPECT_THROW(saveReferenceSweeps(ref.string(), {sweepFile(a, kA)}), std::runtime_error);
  EXPECT_EQ(loadReference(ref.string()).views.origins.size(), 2u);
  fs::remove(ref / "notes.txt");
  saveReferenceSweeps(ref.string(), {sweepFile(b, kB)});
  const ReferenceMap one = loadReference(ref.string());
  EXPECT_EQ(one.views.origins.size(), 1u);
  EXPECT_TRUE(sensorOriginKnown(one.cloud.sensor_origin_));
  // No temporary directories are left beside it.
  std::size_t entries = 0;
  for (const auto& e : fs::directory_iterator(dir)) entries += !e.path().empty();
  EXPECT_EQ(entries, 1u);
  fs::remove_all(dir);
}

TEST(ReferenceSweeps, UnusableDirectoriesAreRefusedByName) {
  const fs::path dir = tempDir("bad");
  auto message = [](const std::string& path) {
    try {
      loadReference(path);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("loaded");
  };
  EXPECT_NE(message(dir.string()).find("without *.pcd"), std::string::npos);
  std::ofstream(dir / "sweep_0000.pcd") << "not a pcd";
  EXPECT_NE(message(dir.string()).find("sweep_0000.pcd"), std::string::npos);
  EXPECT_NE(message((dir / "missing").string()).find("no such file"), std::string::npos);
  // Saving over a file, or into a missing parent, fails with the path named.
  std::ofstream(dir / "plain") << "x";
  const CloudFile f = sweepFile(sweepFrom(kA, {}, false, 1).cloud, kA);
  EXPECT_THROW(saveReferenceSweeps((dir / "plain").string(), {f}), std::runtime_error);
  EXPECT_THROW(saveReferenceSweeps((dir / "no" / "such").string(), {f}), std::runtime_error);
  EXPECT_THROW(saveReferenceSweeps((dir / "r").string(), {}), std::runtime_error);
  fs::remove_all(dir);
}

TEST(ReferenceSweeps, CommandLineTakesADirectory) {
  const fs::path dir = tempDir("cli");
  const Cloud a = sweepFrom(kA, {kPillar}, false, 1).cloud;
  const Cloud b = sweepFrom(kB, {kPillar}, true, 2).cloud;
  saveReferenceSweeps((dir / "route").string(), {sweepFile(a, kA), sweepFile(b, kB)});
  const synthetic::Scene current = sweepFrom(kC, {kPillar, kObject}, true, 3);
  CloudFile cur = sweepFile(current.cloud, kC);
  saveCloudAtomic((dir / "cur.pcd").string(), cur.cloud, cur.T_frame_sensor);
  const std::string base = std::string(NOVELTY_BIN_DIR) + "/novelty_detect --reference " +
                           (dir / "route").string() + " --current " + (dir / "cur.pcd").string() +
                           " --out " + (dir / "out").string();
  ASSERT_EQ(std::system((base + " > /dev/null 2>&1").c_str()), 0);
  std::ifstream in(dir / "out" / "report.json");
  const nlohmann::json report = nlohmann::json::parse(in);
  EXPECT_TRUE(report["visibility_checked"].get<bool>());
  EXPECT_EQ(report["sensor_origins"]["reference"]["sweeps"].get<int>(), 2);
  EXPECT_GE(report["num_segments"].get<int>(), 1);
  std::ifstream labels(dir / "out" / "disappeared_labels.txt");
  std::size_t lines = 0;
  for (std::string line; std::getline(labels, line);) ++lines;
  EXPECT_EQ(lines, a.size() + b.size());  // one per point of the merged sweeps
  // A route map keeps its model beside its sweeps: the next run reads it back, and the
  // cache is not taken for a sweep.
  EXPECT_EQ(report["reference_cache"]["state"], "written");
  const std::string key = report["reference_cache"]["key"];
  EXPECT_TRUE(fs::exists(dir / "route" / ".model_cache" / (key + ".refmodel")));
  ASSERT_EQ(std::system((base + " > /dev/null 2>&1").c_str()), 0);
  std::ifstream again(dir / "out" / "report.json");
  const nlohmann::json second = nlohmann::json::parse(again);
  EXPECT_EQ(second["reference_cache"]["state"], "hit");
  EXPECT_EQ(second["sensor_origins"]["reference"]["sweeps"].get<int>(), 2);
  EXPECT_EQ(second["num_segments"], report["num_segments"]);
  ASSERT_EQ(std::system((base + " --reference-cache off > /dev/null 2>&1").c_str()), 0);
  std::ifstream off(dir / "out" / "report.json");
  EXPECT_EQ(nlohmann::json::parse(off)["reference_cache"]["state"], "off");
  // Each sweep states its origin: a reference origin on top is refused.
  const int code = std::system((base + " --reference-origin 0 0 1 > /dev/null 2>&1").c_str());
  EXPECT_EQ(WEXITSTATUS(code), 1);
  fs::remove_all(dir);
}
