// Simulator scenes for viewpoint robustness: localisation error, removed objects,
// newly-visible ground truth, the viewpoint suite; the voxel-difference baseline; scoring
// per scene group. Known answers from seeded scenes and hand-made worlds.
// Long by design: each case is a seeded scene with its known answer, kept beside its peers.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include "novelty_detection/eval/baseline.h"
#include "novelty_detection/eval/evaluation.h"
#include "novelty_detection/eval/viewpoint_evaluation.h"
#include "novelty_detection/io/cloud_io.h"
#include "novelty_detection/sim/scene.h"

namespace fs = std::filesystem;
using namespace novelty_detection;
using namespace novelty_detection::sim;

namespace {

constexpr double kDeg = M_PI / 180.0;

std::size_t countNonZero(const std::vector<std::uint8_t>& v) {
  return static_cast<std::size_t>(std::count_if(v.begin(), v.end(), [](auto x) { return x; }));
}

const ObjectDescription* findKind(const ScenePair& s, NoveltyKind kind) {
  for (const auto& o : s.objects)
    if (o.kind == kind) return &o;
  return nullptr;
}

// Normalised "radius" of p in a box or upright cylinder part: 1 on its surface, < 1 inside.
double partRadius(const ObjectPart& part, const Eigen::Vector3d& p) {
  const Eigen::Vector3d q = part.sq.rotation().transpose() * (p - part.sq.position);
  const Eigen::Vector3d& a = part.sq.a;
  if (part.shape == "cylinder")
    return std::max(std::hypot(q.x(), q.y()) / a.x(), std::abs(q.z()) / a.z());
  return q.cwiseAbs().cwiseQuotient(a).maxCoeff();
}

Eigen::Vector3d toVec(const PointT& p) { return Eigen::Vector3d(p.x, p.y, p.z); }

}  // namespace

TEST(SimViewpoint, LocalisationErrorIsExactlyApplied) {
  SceneConfig c;
  c.seed = 21;
  c.novelty_kinds = {NoveltyKind::kBox};
  const ScenePair exact = generateScenePair(c);
  c.localisation_error << 0.02, -0.01, 0.005, 0.3 * kDeg, -0.2 * kDeg, 0.5 * kDeg;
  const ScenePair off = generateScenePair(c);

  // In the true sensor frame the error is the configured one.
  const Eigen::Isometry3d E =
      off.T_world_sensor_current.inverse() * off.T_error * off.T_world_sensor_current;
  EXPECT_LT((E.translation() - Eigen::Vector3d(0.02, -0.01, 0.005)).norm(), 1e-12);
  const Eigen::Matrix3d R_expected = (Eigen::AngleAxisd(0.5 * kDeg, Eigen::Vector3d::UnitZ()) *
                                      Eigen::AngleAxisd(-0.2 * kDeg, Eigen::Vector3d::UnitY()) *
                                      Eigen::AngleAxisd(0.3 * kDeg, Eigen::Vector3d::UnitX()))
                                         .toRotationMatrix();
  EXPECT_LT((E.linear() - R_expected).norm(), 1e-12);
  EXPECT_TRUE(exact.T_error.isApprox(Eigen::Isometry3d::Identity()));

  // Same sweep, delivered in the erroneous frame: T_error^-1 maps every point back.
  ASSERT_EQ(off.current.size(), exact.current.size());
  EXPECT_EQ(off.current_labels, exact.current_labels);
  EXPECT_EQ(off.reference.size(), exact.reference.size());
  const Eigen::Isometry3d back = off.T_error.inverse();
  double worst = 0.0, shift = 0.0;
  for (std::size_t i = 0; i < off.current.size(); ++i) {
    worst = std::max(worst, (back * toVec(off.current[i]) - toVec(exact.current[i])).norm());
    shift = std::max(shift, (toVec(off.current[i]) - toVec(exact.current[i])).norm());
  }
  EXPECT_LT(worst, 5e-5);  // float storage of points up to ~15 m away
  EXPECT_GT(shift, 0.02);  // and the error really moved them
  // The cloud reports the erroneous sensor pose, as a robot would.
  const Eigen::Vector3d reported = (off.T_error * off.T_world_sensor_current).translation();
  EXPECT_LT((off.current.sensor_origin_.head<3>().cast<double>() - reported).norm(), 1e-5);
  EXPECT_NEAR((reported - off.T_world_sensor_current.translation()).norm(),
              std::sqrt(0.02 * 0.02 + 0.01 * 0.01 + 0.005 * 0.005), 1e-9);
  EXPECT_LT((exact.current.sensor_origin_.head<3>().cast<double>() -
             exact.T_world_sensor_current.translation())
                .norm(),
            1e-6);
  EXPECT_LT((off.reference.sensor_origin_.head<3>().cast<double>() -
             off.T_world_sensor_reference.translation())
                .norm(),
            1e-6);
  EXPECT_EQ(sceneGroup(off.config), "localisation_error");
  EXPECT_EQ(sceneGroup(exact.config), "same_pose");
}

TEST(SimViewpoint, RemovedObjectReferenceLabelsMatchItsGeometry) {
  for (std::uint64_t seed : {3u, 8u}) {
    SceneConfig c;
    c.seed = seed;
    c.laser.noise_variance_m2 = 0.0;
    c.novelty_kinds = {NoveltyKind::kRemovedObject};
    const ScenePair s = generateScenePair(c);
    const ObjectDescription* o = findKind(s, NoveltyKind::kRemovedObject);
    ASSERT_NE(o, nullptr) << "seed " << seed;
    ASSERT_EQ(o->parts.size(), 1u);
    const ObjectPart& part = o->parts[0];
    EXPECT_TRUE(part.shape == "box" || part.shape == "cylinder");
    EXPECT_EQ(o->points, 0);
    EXPECT_GE(o->reference_points, c.min_object_points);
    ASSERT_EQ(s.reference_labels.size(), s.reference.size());

    int labelled = 0;
    for (std::size_t i = 0; i < s.reference.size(); ++i) {
      const double r = partRadius(part, toVec(s.reference[i]));
      if (s.reference_labels[i] == o->id) {
        ++labelled;
        EXPECT_NEAR(r, 1.0, 1e-4) << "labelled point off the removed object's surface";
      } else {
        EXPECT_EQ(s.reference_labels[i], 0);
        EXPECT_GT(r, 1.0 - 1e-3) << "unlabelled point inside the removed object";
      }
    }
    EXPECT_EQ(labelled, o->reference_points);
    // Gone from the current sweep: no label, and the current sensor now sees the floor
    // where it stood.
    EXPECT_EQ(std::count(s.current_labels.begin(), s.current_labels.end(), o->id), 0);
    int floor_seen = 0;
    for (const auto& p : s.current) floor_seen += partRadius(part, toVec(p)) <= 1.0 + 1e-4;
    EXPECT_GT(floor_seen, 0) << "seed " << seed;
  }
}

TEST(SimViewpoint, MovedObjectOldPlaceIsLabelledInTheReference) {
  SceneConfig c;
  c.seed = 4;
  c.laser.noise_variance_m2 = 0.0;
  c.novelty_kinds = {NoveltyKind::kMovedObject};
  const ScenePair s = generateScenePair(c);
  const ObjectDescription* o = findKind(s, NoveltyKind::kMovedObject);
  ASSERT_NE(o, nullptr);
  ObjectPart old_part = o->parts[0];  // same box, at the reference pose
  old_part.sq.position =
      Eigen::Vector3d(o->reference_pose.x(), o->reference_pose.y(), old_part.sq.a.z());
  old_part.sq.euler = Eigen::Vector3d(o->reference_pose.z(), 0, 0);
  EXPECT_GT(o->reference_points, 0);
  for (std::size_t i = 0; i < s.reference.size(); ++i) {
    if (s.reference_labels[i] == o->id) {
      EXPECT_NEAR(partRadius(old_part, toVec(s.reference[i])), 1.0, 1e-4);
    }
  }
}

TEST(SimViewpoint, UnchangedSamePoseSceneHasNothingNewlyVisible) {
  for (Layout layout : {Layout::kCorridor, Layout::kOffice}) {
    SceneConfig c;
    c.seed = 9;
    c.layout = layout;
    c.novelty_count = 0;
    const ScenePair s = generateScenePair(c);
    EXPECT_TRUE(s.objects.empty());
    EXPECT_GT(s.current.size(), 10000u);
    ASSERT_EQ(s.current_newly_visible.size(), s.current.size());
    EXPECT_EQ(countNonZero(s.current_newly_visible), 0u);
    EXPECT_EQ(std::count(s.current_labels.begin(), s.current_labels.end(), 0),
              static_cast<long>(s.current.size()));
    EXPECT_EQ(std::count(s.reference_labels.begin(), s.reference_labels.end(), 0),
              static_cast<long>(s.reference.size()));
  }
}

TEST(SimViewpoint, NewlyVisibleMaskOfAHandMadeWorld) {
  // Reference laser at (0, 0, 0.6) looking along +x; a wall at x = 5 and a box occluder.
  World w;
  w.add(std::make_shared<Quad>(Eigen::Vector3d(5, 0, 1), Eigen::Vector3d::UnitY(),
                               Eigen::Vector3d::UnitZ(), 10, 5));
  w.add(std::make_shared<OrientedBox>(Eigen::Vector3d(2, 0, 0.6), Eigen::Matrix3d::Identity(),
                                      Eigen::Vector3d(0.2, 0.5, 0.5)));
  const Eigen::Isometry3d T = sensorPose(0, 0, 0, 0.6);
  LaserConfig laser;  // 270 deg, tilt -30..45 deg, 0.1..30 m
  auto dir = [](double az_deg, double tilt_deg) {
    return beamDirection(az_deg * kDeg, tilt_deg * kDeg);
  };
  const Eigen::Vector3d o(0, 0, 0.6);
  const std::vector<Eigen::Vector3d> pts = {
      {5, 0, 0.6},           // on the wall, behind the box: hidden
      {5, 3, 0.6},           // on the wall, in view
      {5, 0, 0.6},           // hidden, but on a changed object (label 2): not counted
      {-5, 0, 0.6},          // straight behind: outside the 270 deg
      {40, 0, 0.6},          // beyond max range
      o + 2.0 * dir(0, 40),  // 40 deg down in front: inside the tilt range
      o + 2.0 * dir(0, 50),  // 50 deg down: outside
      o + 2.0 * Eigen::Vector3d(-0.3, 1, 0).normalized(),  // back half, seen at azimuth 107
      o + 0.05 * Eigen::Vector3d::UnitX(),                 // closer than min range
      o + 3.0 * Eigen::Vector3d::UnitY(),  // along the tilt axis: every line reaches it
  };
  const std::vector<int> labels = {0, 0, 2, 0, 0, 0, 0, 0, 0, 0};
  const std::vector<std::uint8_t> mask = newlyVisibleMask(w, T, laser, pts, labels);
  EXPECT_EQ(mask, (std::vector<std::uint8_t>{1, 0, 0, 1, 1, 0, 1, 0, 1, 0}));
  EXPECT_THROW(newlyVisibleMask(w, T, laser, pts, {0}), std::invalid_argument);
}

TEST(SimViewpoint, ShiftedPoseSeesSurfacesTheReferenceDidNot) {
  SceneConfig c;
  c.seed = 9;
  c.layout = Layout::kOffice;
  c.novelty_count = 0;
  c.pose_offset = Eigen::Vector3d(0.25, 0.1, 8 * kDeg);
  const ScenePair s = generateScenePair(c);
  const std::size_t nv = countNonZero(s.current_newly_visible);
  EXPECT_GT(nv, 0u);
  EXPECT_LT(nv, s.current.size() / 5);
  EXPECT_EQ(sceneGroup(c), "pose_offset");
}

TEST(SimViewpoint, ViewpointSuiteCyclesGroupsWithRemovals) {
  int removals = 0, groups[3] = {0, 0, 0};
  for (int i = 0; i < 36; ++i) {
    const SceneConfig c = viewpointSceneConfig(i, 1);
    const std::string g = sceneGroup(c);
    EXPECT_EQ(g, i % 3 == 0 ? "same_pose" : i % 3 == 1 ? "pose_offset" : "localisation_error");
    ++groups[i % 3];
    const bool removal =
        std::count(c.novelty_kinds.begin(), c.novelty_kinds.end(), NoveltyKind::kRemovedObject) > 0;
    removals += removal;
    if (i % 3 == 1) {
      const double m = c.pose_offset.head<2>().norm();
      EXPECT_GE(m, 0.05);
      EXPECT_LE(m, 0.30);
      EXPECT_LE(std::abs(c.pose_offset.z()), 10 * kDeg + 1e-12);
    }
    if (i % 3 == 2) {
      EXPECT_LE(c.localisation_error.head<3>().norm(), 0.03);
      const Eigen::Matrix3d R =
          (Eigen::AngleAxisd(c.localisation_error(5), Eigen::Vector3d::UnitZ()) *
           Eigen::AngleAxisd(c.localisation_error(4), Eigen::Vector3d::UnitY()) *
           Eigen::AngleAxisd(c.localisation_error(3), Eigen::Vector3d::UnitX()))
              .toRotationMatrix();
      EXPECT_LE(Eigen::AngleAxisd(R).angle(), 1.0 * kDeg);
      EXPECT_TRUE(c.pose_offset.isZero());
    }
    EXPECT_EQ(c.seed, viewpointSceneConfig(i, 1).seed);
  }
  EXPECT_GE(removals, 12);
  EXPECT_EQ(groups[0], 12);
}

TEST(SimViewpoint, BaselineFindsABoxInsertedOnASamePoseScene) {
  SceneConfig c;
  c.seed = 12;  // not among the scenes the defaults were chosen on
  c.novelty_kinds = {NoveltyKind::kBox};
  const ScenePair s = generateScenePair(c);
  const BaselineResult r = detectChangesBaseline(s.reference, s.current);
  EXPECT_GT(r.resolution_m, 0.0);
  ASSERT_EQ(r.labels.size(), s.current.size());
  ASSERT_EQ(r.disappeared_labels.size(), s.reference.size());
  const SceneScore score = scoreLabels(r.labels, s.current_labels);
  EXPECT_GE(score.f1, 0.8);
  EXPECT_EQ(score.objects_found, 1);
}

TEST(SimViewpoint, BaselineReportsARemovedObjectAsDisappeared) {
  SceneConfig c;
  c.seed = 3;
  c.novelty_kinds = {NoveltyKind::kRemovedObject};
  const ScenePair s = generateScenePair(c);
  const BaselineResult r = detectChangesBaseline(s.reference, s.current);
  const SceneScore score = scoreLabels(r.disappeared_labels, s.reference_labels);
  EXPECT_EQ(score.objects_found, 1);
}

TEST(SimViewpoint, BaselineDegenerateInputs) {
  Cloud empty, one;
  one.push_back(PointT(1, 2, 3));
  EXPECT_THROW(detectChangesBaseline(empty, one), std::invalid_argument);
  BaselineOptions fixed;
  fixed.resolution_m = 0.1;
  const BaselineResult r = detectChangesBaseline(empty, one, fixed);
  EXPECT_EQ(r.labels, std::vector<int>{0});  // one point is below min_cluster_size (30)
  fixed.min_cluster_size = 1;
  EXPECT_EQ(detectChangesBaseline(empty, one, fixed).labels, std::vector<int>{1});
  EXPECT_TRUE(detectChangesBaseline(one, empty, fixed).labels.empty());
  BaselineOptions bad;
  bad.min_cluster_size = 0;
  EXPECT_THROW(detectChangesBaseline(one, one, bad), std::invalid_argument);
  Cloud nan_cloud = one;
  nan_cloud.push_back(PointT(NAN, 0, 0));
  EXPECT_EQ(detectChangesBaseline(empty, nan_cloud, fixed).labels, (std::vector<int>{1, 0}));
}

namespace {
void writeLines(const fs::path& p, const std::vector<int>& v) {
  std::ofstream f(p);
  for (int x : v) f << x << "\n";
}
}  // namespace

TEST(SimViewpoint, GroupScoresCountDisappearancesAndNewlyVisible) {
  const fs::path root = fs::path(::testing::TempDir()) / "novelty_viewpoint_eval";
  fs::remove_all(root);
  const fs::path a = root / "suite" / "scene_000", ra = root / "results" / "scene_000";
  const fs::path b = root / "suite" / "scene_001", rb = root / "results" / "scene_001";
  for (const auto& d : {a, ra, b, rb}) fs::create_directories(d);
  // Scene a: removal of object 2 (4 reference points), appearance of object 1.
  std::ofstream(a / "scene.json") << R"({"group": "pose_offset", "removed_objects": [2]})";
  const std::vector<int> gt_a = {0, 1, 1, 0, 0, 0};
  writeLines(a / "gt_labels.txt", gt_a);
  writeLines(a / "gt_disappeared_labels.txt", {0, 2, 2, 2, 2, 0, 0});
  writeLines(a / "gt_newly_visible.txt", {1, 0, 0, 1, 1, 0});
  const std::vector<int> pred_a = {1, 1, 1, 0, 0, 0};  // one newly visible point flagged
  writeLines(ra / "labels.txt", pred_a);
  // Scene b: same pose, removal without a disappeared_labels.txt.
  std::ofstream(b / "scene.json") << R"({"group": "same_pose", "removed_objects": [1]})";
  writeLines(b / "gt_labels.txt", {0, 0, 0});
  writeLines(b / "gt_disappeared_labels.txt", {1, 1, 0});
  writeLines(b / "gt_newly_visible.txt", {0, 0, 0});
  writeLines(rb / "labels.txt", {0, 0, 0});

  // a: without the file, the removal is not found; with 3 of 4 points it is (IoU 0.75).
  ViewpointSceneScore va =
      scoreViewpointScene("scene_000", a.string(), ra.string(), scoreLabels(pred_a, gt_a), true);
  EXPECT_EQ(va.removed_found, 0);
  EXPECT_EQ(va.disappeared_note, "missing disappeared_labels.txt");
  writeLines(ra / "disappeared_labels.txt", {0, 5, 5, 5, 0, 0, 0});
  va = scoreViewpointScene("scene_000", a.string(), ra.string(), scoreLabels(pred_a, gt_a), true);
  EXPECT_EQ(va.group, "pose_offset");
  EXPECT_TRUE(va.has_disappeared);
  EXPECT_EQ(va.removed_found, 1);
  EXPECT_EQ(va.newly_visible_points, 3u);
  EXPECT_EQ(va.newly_visible_novel, 1u);
  const ViewpointSceneScore vb = scoreViewpointScene("scene_001", b.string(), rb.string(),
                                                     scoreLabels({0, 0, 0}, {0, 0, 0}), true);
  EXPECT_EQ(vb.removed_found, 0);
  EXPECT_FALSE(vb.has_appearances);

  const std::vector<GroupSummary> g = summarizeGroups({va, vb});
  ASSERT_EQ(g.size(), 3u);
  EXPECT_EQ(g[0].group, "same_pose");
  EXPECT_EQ(g[0].removal_scenes, 1);
  EXPECT_EQ(g[0].removal_scenes_found, 0);
  EXPECT_EQ(g[0].removal_scenes_without_result, 1);
  EXPECT_EQ(g[0].appearance_scenes, 0);
  EXPECT_EQ(g[0].successes, 1);
  EXPECT_EQ(g[1].group, "pose_offset");
  EXPECT_EQ(g[1].removal_scenes_found, 1);
  EXPECT_NEAR(g[1].mean_f1, 0.8, 1e-12);  // P = 2/3, R = 1
  EXPECT_NEAR(g[1].newly_visible_novel_fraction, 1.0 / 3.0, 1e-12);
  EXPECT_EQ(g[2].group, "all");
  EXPECT_EQ(g[2].scenes, 2);
  EXPECT_EQ(g[2].removal_scenes_found, 1);
  const std::string md = groupsMarkdown(g);
  EXPECT_NE(md.find("| pose_offset | 1 |"), std::string::npos);
  EXPECT_NE(md.find("without disappeared_labels.txt"), std::string::npos);
}

namespace {
int runQuiet(const std::string& cmd) {
  const int rc = std::system((cmd + " > /dev/null 2>&1").c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}
std::size_t lineCount(const fs::path& p) {
  std::ifstream f(p);
  std::size_t n = 0;
  std::string line;
  while (std::getline(f, line)) ++n;
  return n;
}
}  // namespace

TEST(SimViewpoint, ToolsWriteTheViewpointSuiteAndScoreItPerGroup) {
  const std::string bin = NOVELTY_BIN_DIR;
  const fs::path root = fs::path(::testing::TempDir()) / "novelty_viewpoint_tools";
  fs::remove_all(root);
  const fs::path suite = root / "suite", ours = root / "ours", base = root / "base";
  ASSERT_EQ(runQuiet(bin + "/simulate_scans --out " + suite.string() +
                     " --suite 6 --suite-kind viewpoint --lines 10 --no-bag"),
            0);
  for (int i = 0; i < 6; ++i) {
    const fs::path d = suite / ("scene_00" + std::to_string(i));
    const CloudFile ref = loadCloudFile((d / "ref.pcd").string());
    const CloudFile cur = loadCloudFile((d / "cur.pcd").string());
    EXPECT_EQ(lineCount(d / "gt_disappeared_labels.txt"), ref.cloud.size());
    EXPECT_EQ(lineCount(d / "gt_newly_visible.txt"), cur.cloud.size());
    std::ifstream f(d / "scene.json");
    std::stringstream ss;
    ss << f.rdbuf();
    const char* group = i % 3 == 0   ? "same_pose"
                        : i % 3 == 1 ? "pose_offset"
                                     : "localisation_error";
    EXPECT_NE(ss.str().find(std::string("\"group\": \"") + group + "\""), std::string::npos);
    EXPECT_NE(ss.str().find("\"T_error\""), std::string::npos);
    // Baseline with the detector's contract: one label per point of each cloud.
    const fs::path out = base / d.filename();
    ASSERT_EQ(runQuiet(bin + "/baseline_detect --reference " + (d / "ref.pcd").string() +
                       " --current " + (d / "cur.pcd").string() + " --out " + out.string()),
              0);
    EXPECT_EQ(lineCount(out / "labels.txt"), cur.cloud.size());
    EXPECT_EQ(lineCount(out / "disappeared_labels.txt"), ref.cloud.size());
    // "Perfect" appearance labels without disappearance files.
    fs::create_directories(ours / d.filename());
    fs::copy_file(d / "gt_labels.txt", ours / d.filename() / "labels.txt");
  }
  EXPECT_TRUE(fs::exists(suite / "scene_003" / "scene.json"));
  ASSERT_EQ(runQuiet(bin + "/evaluate --suite " + suite.string() + " --results " + ours.string() +
                     " --json " + (root / "ours.json").string()),
            0);
  std::ifstream f(root / "ours.json");
  std::stringstream ss;
  ss << f.rdbuf();
  const std::string j = ss.str();
  EXPECT_NE(j.find("\"groups\""), std::string::npos);
  EXPECT_NE(j.find("\"group\": \"localisation_error\""), std::string::npos);
  // Scenes 3-5 have a removed object; without disappeared_labels.txt none is found.
  EXPECT_NE(j.find("\"removal_scenes_without_result\": 3"), std::string::npos);
  ASSERT_EQ(runQuiet(bin + "/evaluate --suite " + suite.string() + " --results " + base.string()),
            0);
  EXPECT_EQ(runQuiet(bin + "/baseline_detect --reference x.pcd"), 2);
  EXPECT_EQ(runQuiet(bin + "/simulate_scans --out " + root.string() + " --suite-kind viewpoint"),
            2);
}

TEST(SimViewpoint, BaselineOptionsFromYaml) {
  const fs::path dir = fs::path(::testing::TempDir()) / "novelty_baseline_yaml";
  fs::create_directories(dir);
  std::ofstream(dir / "ok.yaml") << "baseline:\n  resolution_m: 0.2\n  min_cluster_size: 5\n";
  const BaselineOptions o = loadBaselineOptions((dir / "ok.yaml").string());
  EXPECT_DOUBLE_EQ(o.resolution_m, 0.2);
  EXPECT_EQ(o.min_cluster_size, 5);
  EXPECT_DOUBLE_EQ(o.cluster_tolerance_factor, BaselineOptions{}.cluster_tolerance_factor);
  std::ofstream(dir / "type.yaml") << "min_cluster_size: many\n";
  std::ofstream(dir / "range.yaml") << "resolution_factor: -1\n";
  for (const char* f : {"type.yaml", "range.yaml", "missing.yaml"}) {
    try {
      loadBaselineOptions((dir / f).string());
      ADD_FAILURE() << f << " was accepted";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(f), std::string::npos) << e.what();
    }
  }
}
