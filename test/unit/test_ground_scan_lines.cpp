// Ground plane on a tilting laser's sweep whose near-horizontal scan lines hold more points
// than the floor (preprocess.h, findGroundPlane): known answer, the simulated floor z = 0.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "novelty_detection/preprocess/preprocess.h"
#include "novelty_detection/sim/scene.h"

using namespace novelty_detection;

namespace {

/// Distance of the plane n.p + d = 0 (unit n) from z = 0 at the origin, and its tilt.
void expectFloor(const GroundPlane& g, const char* what) {
  ASSERT_TRUE(g.found) << what;
  const Eigen::Vector3d n = g.coefficients.head<3>().normalized();
  const double d = g.coefficients[3] / g.coefficients.head<3>().norm();
  EXPECT_GT(n.z(), std::cos(0.5 * M_PI / 180.0)) << what;
  EXPECT_LT(std::abs(d), 0.01) << what;
  EXPECT_LT(g.threshold_m, 0.06) << what;  // floor noise ~1.3 cm, k = 3
}

}  // namespace

TEST(GroundPlane, ScanLinePlaneThroughTheSensorIsNotTheFloor) {
  // Suite scene 19 (seed 2): a corridor seen from a shifted pose, where the scan lines
  // around horizontal hold more points near one plane through the sensor than the floor
  // holds. Taking that plane for the ground (a wide noise band around it) removed most of
  // the sweep and of a moved cabinet.
  const sim::ScenePair s = sim::generateScenePair(sim::suiteSceneConfig(19, 2));
  const Indices all = finiteIndices(s.current);
  const Eigen::Vector3f origin = s.current.sensor_origin_.head<3>();
  PreprocessParams p;
  // With the sensor origin: planes through (or above) the sensor are no hypotheses.
  expectFloor(findGroundPlane(s.current, all, p, &origin), "with origin");
  // Without it, the hypotheses from the lowest fifth of the points still find the floor.
  expectFloor(findGroundPlane(s.current, all, p), "without origin");
  // The preprocessor uses the cloud's origin: the moved object keeps its points.
  const PreprocessResult r = Preprocessor(p).compute(s.current);
  long object = 0, ground = 0;
  std::vector<char> on_ground(s.current.size(), 0);
  for (int i : r.ground.inliers) on_ground[static_cast<std::size_t>(i)] = 1;
  for (std::size_t i = 0; i < s.current.size(); ++i) {
    if (s.current_labels[i] <= 0) continue;
    ++object;
    ground += on_ground[i];
  }
  std::printf(
      "suite seed 2 scene 19: ground threshold %.1f cm, %zu inliers; %ld of %ld object "
      "points on it\n",
      100.0 * r.ground.threshold_m, r.ground.inliers.size(), ground, object);
  EXPECT_GT(object, 2000);
  EXPECT_LT(ground, object / 20);
}
