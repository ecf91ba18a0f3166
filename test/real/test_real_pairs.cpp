// Real scans with known answers: the Kinect tabletop pairs (labelled objects added, replaced
// or moved; camera optical frame) and the ETH apartment pair (tilting laser, each cloud in
// its sensor frame, the published registration). The data set lives outside the repository
// (NOVELTY_REAL_DATA, set by scripts/test.sh); without it every test is skipped. Each test
// prints one row of the real-data table (scripts/evaluate_real.sh collects them).
#include <gtest/gtest.h>

#include <pcl/PCLPointCloud2.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "novelty_detection/alignment/alignment.h"
#include "novelty_detection/eval/evaluation.h"
#include "novelty_detection/io/cloud_io.h"
#include "novelty_detection/pipeline.h"

namespace fs = std::filesystem;
using namespace novelty_detection;

namespace {

fs::path dataDir() {
  const char* d = std::getenv("NOVELTY_REAL_DATA");
  return d ? fs::path(d) : fs::path();
}

#define REQUIRE_DATA(path)                           \
  if (dataDir().empty() || !fs::exists(path))        \
  GTEST_SKIP() << "real data not found (" << (path)  \
               << "); set NOVELTY_REAL_DATA to the " \
                  "directory that holds the real-scan folders"

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
}

INSTANTIATE_TEST_SUITE_P(Osd, KinectPairs,
                         ::testing::Values(KinectCase{"test14.pcd", "test15.pcd", {2}, 0.93},
                                           KinectCase{"learn11.pcd", "learn12.pcd", {3}, 0.78},
                                           KinectCase{
                                               "test31.pcd", "test32.pcd", {3, 4, 5}, 0.80}));

// The ETH apartment pair: the same place seen from two poses a few seconds apart, each in its
// own sensor frame; cloud_1 is put into cloud_0's frame with the published registration.
TEST(EthApartment, UnchangedPairFlagsLittle) {
  const fs::path dir = dataDir() / "eth_apartment_tilting_hokuyo";
  REQUIRE_DATA(dir / "cloud_1.pcd");
  Cloud ref = loadCloud((dir / "cloud_0.pcd").string());
  Cloud cur = loadCloud((dir / "cloud_1.pcd").string());
  Eigen::Matrix4d m;
  m << 0.993552, -0.113149, 0.00713103, 0.60831, 0.113181, 0.993565, -0.00425984, -0.00387758,
      -0.00660312, 0.00503951, 0.999965, 0.0107267, 0, 0, 0, 1;
  Eigen::Isometry3d T(m);
  setSensorOrigin(ref, Eigen::Vector3f::Zero());
  setSensorOrigin(cur, Eigen::Vector3f::Zero());
  cur = transformCloud(cur, T);  // the origin moves with it
  for (const std::string up : {"0 0 1", "auto"}) {
    Params p;
    p.preprocess.up = up;
    p.superquadric.enabled = false;
    Pipeline pipeline(p);
    pipeline.setReference(ref);
    const Result r = pipeline.detect(cur);
    std::size_t novel = 0, near_sensor = 0;
    const Eigen::Vector3f origin = cur.sensor_origin_.head<3>();
    for (std::size_t i = 0; i < r.labels.size(); ++i) {
      if (r.labels[i] == 0) continue;
      ++novel;
      near_sensor += (cur[i].getVector3fMap() - origin).norm() < 1.0f;
    }
    const double share = static_cast<double>(novel) / cur.size();
    std::printf(
        "| eth cloud_0 -> cloud_1 | sensor frames, published transform, up %s | %.2f %% of %zu "
        "points novel, %zu within 1 m of the sensor; %zu segments; up (%.2f, %.2f, %.2f) %s; "
        "floor %s |\n",
        up.c_str(), 100.0 * share, cur.size(), near_sensor, r.segments.size(), r.up.x(), r.up.y(),
        r.up.z(), r.up_source.c_str(), r.floor_found ? "found" : "none");
    for (const auto& [stage, n] : r.point_counts) std::printf("  %s %zu\n", stage.c_str(), n);
    for (const Segment& seg : r.segments)
      std::printf("  segment %d: %zu points at (%.2f, %.2f, %.2f), %.2f m from the sensor\n",
                  seg.id, seg.indices.size(), seg.centroid.x(), seg.centroid.y(), seg.centroid.z(),
                  (seg.centroid - origin.cast<double>()).norm());
    EXPECT_TRUE(r.floor_found) << up;
    EXPECT_GT(r.up.z(), 0.99) << up;
    // The pair holds a few small real differences; the robot's own returns are not novel.
    EXPECT_LE(share, 0.01) << up;
    EXPECT_LE(near_sensor, 30u) << up;
    for (const Segment& seg : r.segments)
      EXPECT_GT((seg.centroid - origin.cast<double>()).norm(), 1.0) << "segment on the robot";
  }
}

}  // namespace
