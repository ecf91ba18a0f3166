// Real scans with known answers: the Kinect tabletop pairs (labelled objects added, replaced
// or moved; camera optical frame) and the ETH apartment pair (tilting laser, each cloud in
// its sensor frame, the published registration). The data set lives outside the repository
// (NOVELTY_REAL_DATA, set by scripts/test.sh); without it every test is skipped. Each test
// prints one row of the real-data table (scripts/evaluate_real.sh collects them).
#include <gtest/gtest.h>

#include <pcl/PCLPointCloud2.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "novelty_detection/alignment/alignment.h"
#include "novelty_detection/eval/evaluation.h"
#include "novelty_detection/io/cloud_io.h"
#include "novelty_detection/pipeline.h"
#include "novelty_detection/shape/fit_bounds.h"
#include "real_data.h"

using namespace novelty_detection;
using namespace novelty_detection::real_data;

namespace {

/// A labelled organised Kinect cloud: points (NaNs kept) and the object id per point.
struct Labelled {
  Cloud cloud;
  std::vector<int> object;  ///< label / 10 (0: NaN, 0: table)
};

Labelled loadLabelled(const fs::path& path) {
  pcl::PointCloud<pcl::PointXYZL> l;
  if (pcl::io::loadPCDFile(path.string(), l) != 0)
    throw std::runtime_error("cannot read " + path.string());
  Labelled out;
  out.cloud.resize(l.size());
  out.cloud.width = l.width;
  out.cloud.height = l.height;
  out.cloud.is_dense = false;
  out.object.resize(l.size());
  for (std::size_t i = 0; i < l.size(); ++i) {
    out.cloud[i].x = l[i].x, out.cloud[i].y = l[i].y, out.cloud[i].z = l[i].z;
    out.object[i] = static_cast<int>(l[i].label) / 10;
  }
  return out;
}

void printRow(const std::string& pair, const std::string& how, const SceneScore& s,
              std::size_t segments, const Result& r) {
  std::printf("| %s | %s | %.3f | %.3f | %.3f | %zu | (%.2f, %.2f, %.2f) %s |\n", pair.c_str(),
              how.c_str(), s.precision, s.recall, s.f1, segments, r.up.x(), r.up.y(), r.up.z(),
              r.up_source.c_str());
}

struct KinectCase {
  const char* before;
  const char* after;
  std::set<int> novel;  ///< object ids new in `after`
  double min_f1;        ///< measured with --sensor-frame --up auto, less a margin
  /// Novel objects that touch another object and must come out as their own segment, with
  /// the best-segment IoU each must reach (measured, less a margin).
  std::vector<std::pair<int, double>> apart;
};

class KinectPairs : public ::testing::TestWithParam<KinectCase> {};

// Camera frame (z forward, y down), organised: the sensor is the frame's origin and up is
// estimated from the table; the novel objects' points are scored against the labels.
TEST_P(KinectPairs, SensorFrameAndAutoUp) {
  const KinectCase& c = GetParam();
  const fs::path dir = dataDir() / "osd_tabletop_changes";
  REQUIRE_DATA(dir / c.after);
  Labelled ref = loadLabelled(dir / c.before);
  Labelled cur = loadLabelled(dir / c.after);
  setSensorOrigin(ref.cloud, Eigen::Vector3f::Zero());
  setSensorOrigin(cur.cloud, Eigen::Vector3f::Zero());
  std::vector<int> truth(cur.object.size(), 0);
  for (std::size_t i = 0; i < truth.size(); ++i)
    truth[i] = c.novel.count(cur.object[i]) ? cur.object[i] : 0;
  auto run = [&](const std::string& up, const char* how) {
    Params p;
    p.preprocess.up = up;
    p.superquadric.enabled = false;
    Pipeline pipeline(p);
    pipeline.setReference(ref.cloud);
    Result r = pipeline.detect(cur.cloud);
    const SceneScore s = scoreLabels(r.labels, truth);
    printRow(std::string(c.before) + " -> " + c.after, how, s, r.segments.size(), r);
    return std::make_pair(r, s);
  };
  run("0 0 1", "sensor frame, up +z");
  const auto [r, s] = run("auto", "sensor frame, up auto");
  // Up is the table's normal, pointing at the camera: -y and -z in the optical frame.
  EXPECT_EQ(r.up_source, "plane");
  EXPECT_LT(r.up.y(), -0.5);
  EXPECT_LT(r.up.z(), 0.0);
  EXPECT_GE(s.f1, c.min_f1);
  std::set<int> best_segments;
  for (const auto& [id, min_iou] : c.apart) {
    for (const ObjectScore& o : s.objects) {
      if (o.id != id) continue;
      EXPECT_GE(o.best_iou, min_iou) << "object " << id;
      EXPECT_TRUE(best_segments.insert(o.best_segment).second)
          << "object " << id << " shares its segment with another";
    }
  }
}

// Measured F1: 0.977, 0.955 (the new box lies where a standing one stood, partly behind an
// unchanged box it touches), 0.908 (a tin now lies in front of a can that stands where the
// tin stood, touching it; a new mug on an unchanged tin is found only where it differs from
// the old can there: IoU 0.35). Best-segment IoU of the objects that touch: 0.89; 0.91; 0.95
// and 0.68.
INSTANTIATE_TEST_SUITE_P(
    Osd, KinectPairs,
    ::testing::Values(KinectCase{"test14.pcd", "test15.pcd", {2}, 0.95, {{2, 0.85}}},
                      KinectCase{"learn11.pcd", "learn12.pcd", {3}, 0.93, {{3, 0.85}}},
                      KinectCase{
                          "test31.pcd", "test32.pcd", {3, 4, 5}, 0.9, {{3, 0.9}, {4, 0.6}}}));

// learn11 -> learn12: the new box stands on the table. The camera sees its top and two faces;
// fitted to those alone its superquadric reaches down through the table. Bounded by what the
// camera saw (the table's returns around it lie outside it), it stays above the table.
TEST(KinectBox, RestsOnTheTable) {
  const fs::path dir = dataDir() / "osd_tabletop_changes";
  REQUIRE_DATA(dir / "learn12.pcd");
  Labelled ref = loadLabelled(dir / "learn11.pcd");
  Labelled cur = loadLabelled(dir / "learn12.pcd");
  setSensorOrigin(ref.cloud, Eigen::Vector3f::Zero());
  setSensorOrigin(cur.cloud, Eigen::Vector3f::Zero());
  // Lowest extent of the novel segment's superquadrics below the table plane [m] (> 0: below).
  auto depth_below_table = [&](bool bounded) {
    Params p;
    p.preprocess.up = "auto";
    p.superquadric.bounded_fit = bounded;
    Pipeline pipeline(p);
    pipeline.setReference(ref.cloud);
    const Result r = pipeline.detect(cur.cloud);
    EXPECT_TRUE(r.floor_found);
    EXPECT_EQ(r.segments.size(), 1u);
    EXPECT_FALSE(r.superquadrics.empty());
    const Eigen::Vector3d up = r.floor.head<3>();
    double below = -1.0;
    for (const Superquadric& sq : r.superquadrics)
      below = std::max(below, extentAlong(sq, up) - (up.dot(sq.position) + r.floor[3]));
    return below;
  };
  const double loose = depth_below_table(false), tight = depth_below_table(true);
  std::printf("  box superquadric below the table: %.3f m unbounded, %.3f m bounded\n", loose,
              tight);
  EXPECT_GT(loose, 0.05);
  EXPECT_LT(tight, 0.02);
}

// The ETH apartment pair: the same place seen from two poses a few seconds apart, each in its
// own sensor frame; cloud_1 is put into cloud_0's frame with the published registration.
// It holds a few small real differences where the reference's beams passed through (a
// doorway edge, a shelf edge, a low rail). Measured: 0.68 % novel in 3 segments, the nearest
// 1.0 m from the sensor; the robot's own returns (within 0.5 m) are not reported.
TEST(EthApartment, UnchangedPairFlagsLittle) {
  REQUIRE_DATA(ethDir() / "cloud_1.pcd");
  const Pair pair = ethPair();
  for (const std::string up : {"0 0 1", "auto"}) {
    const Result r = expectUnchangedPairFlagsLittle(pair, "eth cloud_0 -> cloud_1",
                                                    "sensor frames, published transform", up,
                                                    up == "0 0 1" ? "eth_flags.txt" : "");
    EXPECT_GT(r.up.z(), 0.99) << up;
  }
}

}  // namespace

// The floor of the ETH pair does not move with unrelated options: found or not alike, and
// when found the same plane (within 1 cm and 1 degree) and about as many ground points.
// (No plane passes as the floor on this pair yet: its floor holds ~5 % of the points, and
// the planes through the robot's mast and body near the sensor hold more.)
TEST(EthApartment, FloorDoesNotDependOnOtherOptions) {
  REQUIRE_DATA(ethDir() / "cloud_1.pcd");
  const Pair pair = ethPair();
  const Cloud& ref = pair.reference;
  const Cloud& cur = pair.current;
  std::vector<std::pair<std::string, Params>> variants(6);
  variants[0].first = "defaults";
  variants[1].first = "range-scaled outliers";
  variants[1].second.preprocess.outlier_range_scaled = true;
  variants[2].first = "no outlier removal";
  variants[2].second.preprocess.outlier_removal = false;
  variants[3].first = "no visibility rules";
  variants[3].second.segmentation.visibility_check = false;
  variants[3].second.visibility.disappearances = false;
  variants[4].first = "no self filter";
  variants[4].second.preprocess.self_filter = false;
  variants[5].first = "up auto";
  variants[5].second.preprocess.up = "auto";
  std::vector<Eigen::Vector4d> floors;
  std::vector<std::size_t> ground;
  std::vector<bool> found;
  for (auto& [name, p] : variants) {
    p.superquadric.enabled = false;
    Pipeline pipeline(p);
    pipeline.setReference(ref);
    const Result r = pipeline.detect(cur);
    std::size_t before = 0, after = 0;
    for (const auto& [stage, n] : r.point_counts) {
      if (stage == "after_outliers") before = n;
      if (stage == "after_ground") after = n;
    }
    std::printf("  %s: floor %s (%.3f, %.3f, %.3f, %.3f), %zu ground points\n", name.c_str(),
                r.floor_found ? "found" : "none", r.floor[0], r.floor[1], r.floor[2], r.floor[3],
                before - after);
    found.push_back(r.floor_found);
    floors.push_back(r.floor);
    ground.push_back(before - after);
  }
  for (std::size_t k = 1; k < floors.size(); ++k) {
    ASSERT_EQ(found[k], found[0]) << variants[k].first;
    if (!found[0]) continue;
    EXPECT_NEAR(floors[k][3], floors[0][3], 0.01) << variants[k].first;
    EXPECT_GT(floors[k].head<3>().dot(floors[0].head<3>()), std::cos(M_PI / 180))
        << variants[k].first;
    EXPECT_NEAR(double(ground[k]), double(ground[0]), 0.1 * ground[0]) << variants[k].first;
  }
}
