// The fine alignment inside Pipeline::detect: a 2 cm / 0.5 deg localisation error no longer
// shows walls as novelty, outputs are in the map frame, labels keep the input order, and a
// same-pose scene keeps its detection.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "novelty_detection/alignment/alignment.h"
#include "novelty_detection/eval/evaluation.h"
#include "novelty_detection/io/params_io.h"
#include "novelty_detection/pipeline.h"
#include "novelty_detection/sim/scene.h"

using namespace novelty_detection;

namespace {

constexpr double kDeg = M_PI / 180.0;

Params alignedParams() {
  Params p;
  p.alignment.enabled = true;
  return p;
}

/// Range noise sigma = 1 cm (a Hokuyo UTM-30LX class scanner).
sim::ScenePair scene(std::uint64_t seed, sim::NoveltyKind kind) {
  sim::SceneConfig c;
  c.seed = seed;
  c.novelty_kinds = {kind};
  c.laser.noise_variance_m2 = 1e-4;
  return sim::generateScenePair(c);
}

/// Rotation about the sensor origin, then a shift.
Eigen::Isometry3d poseError(const Cloud& c, const Eigen::Vector3d& shift,
                            const Eigen::Vector3d& axis, double angle_deg) {
  const Eigen::Vector3d o = c.sensor_origin_.head<3>().cast<double>();
  Eigen::Isometry3d E = Eigen::Isometry3d::Identity();
  E.linear() = Eigen::AngleAxisd(angle_deg * kDeg, axis.normalized()).toRotationMatrix();
  E.translation() = o - E.linear() * o + shift;
  return E;
}

std::size_t falseNovelPoints(const Result& r, const std::vector<int>& truth) {
  std::size_t fp = 0;
  for (std::size_t i = 0; i < truth.size(); ++i) fp += r.labels[i] > 0 && truth[i] == 0;
  return fp;
}

}  // namespace

TEST(AlignedDetection, LocalisationErrorGivesNoFalseNoveltyOnWalls) {
  for (std::uint64_t seed : {3u, 6u}) {
    const sim::ScenePair s = scene(seed, sim::NoveltyKind::kBox);
    const Eigen::Isometry3d E =
        poseError(s.current, 0.02 * Eigen::Vector3d(1, 1, 0).normalized(), {0, 0, 1}, 0.5);
    const Cloud given = transformCloud(s.current, E);
    Pipeline aligned(alignedParams());
    aligned.setReference(s.reference);
    const Result r = aligned.detect(given);
    ASSERT_TRUE(r.alignment.applied) << r.alignment.status;
    ASSERT_EQ(r.labels.size(), given.size());
    const SceneScore sc = scoreLabels(r.labels, s.current_labels);
    EXPECT_TRUE(sc.success) << "seed " << seed << " f1 " << sc.f1;
    EXPECT_EQ(sc.false_segments, 0) << "seed " << seed;
    EXPECT_LT(falseNovelPoints(r, s.current_labels), 20u) << "seed " << seed;
    bool timed = false;
    for (const auto& t : r.timings) timed |= t.stage == "alignment";
    EXPECT_TRUE(timed);
    // Segments are in the map frame: the box's segment sits where its true points are.
    ASSERT_FALSE(r.segments.empty());
    Eigen::Vector3d truth = Eigen::Vector3d::Zero();
    int n = 0;
    for (int i : r.segments[0].indices) {
      truth += s.current[i].getVector3fMap().cast<double>();
      ++n;
    }
    EXPECT_LT((r.segments[0].centroid - truth / n).norm(), 0.01) << "seed " << seed;
  }
}

// config/localisation_error.yaml turns the alignment on: a sweep whose pose is off by 5 cm
// and 1.5 deg is then compared as if localised (measured: the correction undoes the error to
// the millimetre, F1 0.978, nothing false), while with the defaults the box's segment takes
// in 96 points of the floor and wall around it (F1 0.638).
TEST(AlignedDetection, TheLocalisationErrorConfigRemovesWhatTheDefaultsReport) {
  Params shipped;
  loadParamsYaml(std::string(NOVELTY_SOURCE_DIR) + "/config/localisation_error.yaml", shipped);
  EXPECT_TRUE(shipped.alignment.enabled);
  const sim::ScenePair s = scene(6, sim::NoveltyKind::kBox);
  const Eigen::Isometry3d E =
      poseError(s.current, 0.05 * Eigen::Vector3d(1, -1, 0).normalized(), {1, 1, 0}, 1.5);
  const Cloud given = transformCloud(s.current, E);
  Pipeline plain{Params()}, aligned(shipped);
  plain.setReference(s.reference);
  aligned.setReference(s.reference);
  const Result a = plain.detect(given), b = aligned.detect(given);
  const SceneScore sa = scoreLabels(a.labels, s.current_labels);
  const SceneScore sb = scoreLabels(b.labels, s.current_labels);
  std::printf("defaults: F1 %.3f, %zu false novel points; with the file: F1 %.3f, %zu\n", sa.f1,
              falseNovelPoints(a, s.current_labels), sb.f1, falseNovelPoints(b, s.current_labels));
  EXPECT_FALSE(a.alignment.attempted);
  EXPECT_GT(falseNovelPoints(a, s.current_labels), 50u);
  EXPECT_LT(sa.f1, 0.8);
  ASSERT_TRUE(b.alignment.applied) << b.alignment.status;
  const Eigen::Vector3d o = s.current.sensor_origin_.head<3>().cast<double>();
  const Eigen::Isometry3d left = b.alignment.correction * E;
  EXPECT_LT((left * o - o).norm(), 0.005);
  EXPECT_LT(Eigen::AngleAxisd(left.rotation()).angle() / kDeg, 0.1);
  EXPECT_LT(falseNovelPoints(b, s.current_labels), 20u);
  EXPECT_GT(sb.f1, 0.95);
  EXPECT_TRUE(sb.success);
  EXPECT_EQ(sb.false_segments, 0);
}

TEST(AlignedDetection, SamePoseKeepsTheDetection) {
  for (auto [seed, kind] : {std::make_pair(3u, sim::NoveltyKind::kBox),
                            std::make_pair(5u, sim::NoveltyKind::kCylinder)}) {
    const sim::ScenePair s = scene(seed, kind);
    Pipeline plain{Params()}, aligned(alignedParams());
    plain.setReference(s.reference);
    aligned.setReference(s.reference);
    const Result a = plain.detect(s.current), b = aligned.detect(s.current);
    EXPECT_FALSE(a.alignment.attempted);
    EXPECT_EQ(a.alignment.status, "disabled");
    ASSERT_TRUE(b.alignment.applied) << b.alignment.status;
    EXPECT_LT(b.alignment.translation_m, 0.002) << "seed " << seed;
    EXPECT_LT(b.alignment.rotation_deg, 0.05) << "seed " << seed;
    const SceneScore sa = scoreLabels(a.labels, s.current_labels);
    const SceneScore sb = scoreLabels(b.labels, s.current_labels);
    EXPECT_EQ(sa.success, sb.success) << "seed " << seed;
    EXPECT_NEAR(sa.f1, sb.f1, 0.02) << "seed " << seed;
  }
}

TEST(AlignedDetection, RejectedCorrectionLeavesTheSweepAsGiven) {
  const sim::ScenePair s = scene(3, sim::NoveltyKind::kBox);
  Params p = alignedParams();
  p.alignment.max_translation_m = 0.01;  // the 2 cm error is beyond this bound
  Pipeline pipeline(p);
  pipeline.setReference(s.reference);
  const Result r = pipeline.detect(
      transformCloud(s.current, poseError(s.current, {0.02, 0.0, 0.0}, {0, 0, 1}, 0.0)));
  EXPECT_TRUE(r.alignment.attempted);
  EXPECT_FALSE(r.alignment.applied);
  EXPECT_NE(r.alignment.status.find("max_translation_m"), std::string::npos) << r.alignment.status;
  EXPECT_EQ(r.labels.size(), s.current.size());
}
