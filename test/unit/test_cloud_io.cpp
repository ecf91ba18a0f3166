// Cloud files: round trip, atomic save, clear errors for bad files.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

#include "novelty_detection/cloud_io.h"

using namespace novelty_detection;

namespace {
std::string tmpPath(const std::string& name) {
  return ::testing::TempDir() + "/novelty_cloud_io_" + name;
}
std::string errorOf(const std::string& path) {
  try {
    loadCloud(path);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(CloudIo, RoundTripKeepsPointsNaNsAndViewpoint) {
  Cloud c;
  c.push_back(PointT(1.f, 2.f, 3.f));
  c.push_back(PointT(std::numeric_limits<float>::quiet_NaN(), 0.f, 0.f));
  c.push_back(PointT(-4.f, 5.5f, 0.25f));
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(0.5, -1.0, 1.2);
  T.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const std::string path = tmpPath("rt.pcd");
  saveCloudAtomic(path, c, T);
  const CloudFile f = loadCloudFile(path);
  ASSERT_EQ(f.cloud.size(), 3u);
  EXPECT_FLOAT_EQ(f.cloud[2].y, 5.5f);
  EXPECT_TRUE(std::isnan(f.cloud[1].x));
  EXPECT_NEAR((f.T_frame_sensor.translation() - T.translation()).norm(), 0.0, 1e-6);
  EXPECT_NEAR((f.T_frame_sensor.linear() - T.linear()).norm(), 0.0, 1e-6);
}

TEST(CloudIo, BadFilesGiveSpecificErrors) {
  EXPECT_NE(errorOf("/nonexistent/dir/x.pcd").find("no such file"), std::string::npos);
  const std::string empty = tmpPath("empty.pcd");
  std::ofstream(empty).close();
  EXPECT_NE(errorOf(empty).find("empty file"), std::string::npos);
  const std::string garbage = tmpPath("garbage.pcd");
  std::ofstream(garbage) << "\x01\x02 this is not a point cloud \xff\xfe";
  EXPECT_NE(errorOf(garbage).find("malformed"), std::string::npos);
  const std::string txt = tmpPath("cloud.txt");
  std::ofstream(txt) << "1 2 3\n";
  EXPECT_NE(errorOf(txt).find("unknown extension"), std::string::npos);
  const std::string noxyz = tmpPath("noxyz.pcd");
  std::ofstream(noxyz) << "VERSION .7\nFIELDS intensity\nSIZE 4\nTYPE F\nCOUNT 1\nWIDTH 2\n"
                          "HEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\nDATA ascii\n1\n2\n";
  EXPECT_NE(errorOf(noxyz).find("x, y, z"), std::string::npos);
}

TEST(CloudIo, FailedSaveLeavesPreviousFileIntact) {
  Cloud c;
  c.push_back(PointT(1.f, 1.f, 1.f));
  const std::string path = tmpPath("keep.pcd");
  saveCloudAtomic(path, c);
  EXPECT_THROW(saveCloudAtomic("/nonexistent/dir/x.pcd", c), std::runtime_error);
  EXPECT_EQ(loadCloud(path).size(), 1u);
}
