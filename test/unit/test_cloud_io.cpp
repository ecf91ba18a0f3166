// Cloud files: round trip, atomic save, clear errors for bad files.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "novelty_detection/io/cloud_io.h"

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
  EXPECT_NEAR((f.cloud.sensor_origin_.head<3>().cast<double>() - T.translation()).norm(), 0.0,
              1e-6);
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

// Open3D writes PLY coordinates as doubles by default: they load like double PCDs.
TEST(CloudIo, DoublePlyLoads) {
  const std::string ply = tmpPath("double.ply");
  std::ofstream(ply) << "ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\n"
                        "property double y\nproperty double z\nend_header\n"
                        "1.25 -2.5 3.125\n0.1 0.2 0.3\n";
  const Cloud c = loadCloud(ply);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_FLOAT_EQ(c[0].x, 1.25f);
  EXPECT_FLOAT_EQ(c[0].y, -2.5f);
  EXPECT_FLOAT_EQ(c[0].z, 3.125f);
  EXPECT_FLOAT_EQ(c[1].z, 0.3f);
  // Mixed: float x, double y and z.
  const std::string mixed = tmpPath("mixed.ply");
  std::ofstream(mixed) << "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                          "property double y\nproperty double z\nend_header\n4 5 6\n";
  const Cloud m = loadCloud(mixed);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_FLOAT_EQ(m[0].x + m[0].y + m[0].z, 15.f);
}

// A field given twice is ambiguous (which x?): refused by name, PCD and PLY alike.
TEST(CloudIo, RepeatedFieldsAreRefused) {
  const std::string pcd = tmpPath("twice.pcd");
  std::ofstream(pcd) << "VERSION .7\nFIELDS x y z x\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\n"
                        "WIDTH 1\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 1\nDATA ascii\n"
                        "1 2 3 4\n";
  EXPECT_NE(errorOf(pcd).find("field 'x' given twice"), std::string::npos) << errorOf(pcd);
  const std::string ply = tmpPath("twice.ply");
  std::ofstream(ply) << "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                        "property float y\nproperty float z\nproperty float z\nend_header\n"
                        "1 2 3 4\n";
  EXPECT_NE(errorOf(ply).find("given twice"), std::string::npos) << errorOf(ply);
}

TEST(CloudIo, FailedSaveLeavesPreviousFileIntact) {
  Cloud c;
  c.push_back(PointT(1.f, 1.f, 1.f));
  const std::string path = tmpPath("keep.pcd");
  saveCloudAtomic(path, c);
  EXPECT_THROW(saveCloudAtomic("/nonexistent/dir/x.pcd", c), std::runtime_error);
  EXPECT_EQ(loadCloud(path).size(), 1u);
  try {
    saveCloudAtomic("/nonexistent/dir/x.pcd", c);
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("No such file or directory"), std::string::npos)
        << e.what();
  }
}

// The temporary file is a fresh one: a symlink planted at the name a save would once have
// used (PATH.tmp.<pid>) is not followed, and no temporary file is left behind.
TEST(CloudIo, SaveFollowsNoPlantedLinkAndLeavesNoTemporaryFile) {
  const std::string dir = tmpPath("save_dir");
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string victim = dir + "/victim.txt";
  std::ofstream(victim) << "untouched";
  const std::string path = dir + "/map.pcd";
  std::filesystem::create_symlink(victim, path + ".tmp." + std::to_string(::getpid()));
  Cloud c;
  c.push_back(PointT(1.f, 2.f, 3.f));
  c.push_back(PointT(4.f, 5.f, 6.f));
  saveCloudAtomic(path, c);
  std::ifstream in(victim);
  std::string text;
  in >> text;
  EXPECT_EQ(text, "untouched");
  EXPECT_EQ(loadCloud(path).size(), 2u);
  std::size_t files = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    (void)e;
    ++files;
  }
  EXPECT_EQ(files, 3u);  // victim, the planted link, map.pcd
  std::filesystem::remove_all(dir);
}

TEST(CloudIo, FuzzFindingsStayFixed) {
  // Every file kept under test/fuzz/corpus/cloud_file: its first byte picks the extension
  // (odd: .ply), the rest is the file. Each must load or fail with runtime_error.
  const std::string dir = std::string(NOVELTY_SOURCE_DIR) + "/test/fuzz/corpus/cloud_file/";
  for (const char* name :
       {"regression_float_size2", "regression_duplicate_fields", "regression_ply_negative_count",
        "regression_blank_header_lines", "regression_binary_in_ascii_body",
        "regression_ascii_token_count", "regression_binary_body_columns", "pcd_ascii", "pcd_binary",
        "ply_ascii"}) {
    std::ifstream in(dir + name, std::ios::binary);
    ASSERT_TRUE(in.good()) << name;
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    ASSERT_FALSE(bytes.empty());
    const std::string path = tmpPath(std::string(name) + ((bytes[0] & 1) ? ".ply" : ".pcd"));
    std::ofstream(path, std::ios::binary) << bytes.substr(1);
    try {
      loadCloud(path);
    } catch (const std::runtime_error&) {
    }
  }
  const std::string f = tmpPath("float2.pcd");
  std::ofstream(f) << "VERSION .7\nFIELDS x y z\nSIZE 4 4 2\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\n"
                      "HEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3\n";
  EXPECT_NE(errorOf(f).find("SIZE of a float"), std::string::npos);
  const std::string words = tmpPath("words.pcd");
  std::ofstream(words) << "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                          "WIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\n1 2 3\nFIELDS2550\n";
  EXPECT_NE(errorOf(words).find("non-numeric"), std::string::npos);
  const std::string short_rows = tmpPath("short.pcd");
  std::ofstream(short_rows) << "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                               "WIDTH 3\nHEIGHT 1\nPOINTS 3\nDATA ascii\n1 2 3\n4 5\nnan nan nan\n";
  EXPECT_NE(errorOf(short_rows).find("has 2 values"), std::string::npos);
  const std::string ply = tmpPath("negative.ply");
  std::ofstream(ply) << "ply\nformat ascii 1.0\nelement vertex -1\nproperty float x\n"
                        "property float y\nproperty float z\nend_header\n1 2 3\n";
  EXPECT_NE(errorOf(ply).find("element count"), std::string::npos);
  const std::string big = tmpPath("big.ply");
  std::ofstream(big) << "ply\nformat binary_little_endian 1.0\nelement vertex 40\n"
                        "property float x\nproperty float y\nproperty float z\nend_header\n";
  EXPECT_NE(errorOf(big).find("truncated"), std::string::npos);
}

TEST(CloudIo, EmptyCloudLoadsAsEmpty) {
  const std::string path = tmpPath("zero.pcd");
  std::ofstream(path) << "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                         "WIDTH 0\nHEIGHT 1\nPOINTS 0\nDATA ascii\n";
  // A sweep with no returns is valid data: it loads as an empty cloud.
  EXPECT_EQ(loadCloud(path).size(), 0u);
}
