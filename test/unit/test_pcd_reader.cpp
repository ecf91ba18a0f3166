// The strict PCD reader: same points as PCL's reader on every encoding PCL writes, and a
// clear error for each inconsistency between a header and its body.
#include <gtest/gtest.h>

#include <pcl/io/pcd_io.h>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <random>
#include <sstream>

#include "novelty_detection/io/cloud_io.h"

using namespace novelty_detection;

namespace {

std::string tmpPath(const std::string& name) {
  return ::testing::TempDir() + "/novelty_pcd_reader_" + name;
}

std::string errorOf(const std::string& path) {
  try {
    loadCloud(path);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

/// An organised 7 x 5 cloud with colour (so x, y, z are not the only fields), NaN holes
/// and a viewpoint.
pcl::PointCloud<pcl::PointXYZRGB> sampleCloud(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-5.f, 5.f);
  pcl::PointCloud<pcl::PointXYZRGB> c(7, 5);
  for (auto& p : c.points) {
    p.x = u(rng), p.y = u(rng), p.z = u(rng);
    p.r = static_cast<std::uint8_t>(rng()), p.g = 7, p.b = 200;
  }
  c.at(3, 2).x = c.at(3, 2).y = c.at(3, 2).z = std::numeric_limits<float>::quiet_NaN();
  c.at(0, 4).z = std::numeric_limits<float>::quiet_NaN();
  c.is_dense = false;
  c.sensor_origin_ = Eigen::Vector4f(0.5f, -1.f, 1.25f, 0.f);
  c.sensor_orientation_ = Eigen::Quaternionf(Eigen::AngleAxisf(0.4f, Eigen::Vector3f::UnitZ()));
  return c;
}

void expectSameAsPcl(const std::string& path) {
  pcl::PointCloud<pcl::PointXYZ> expected;
  ASSERT_EQ(pcl::io::loadPCDFile(path, expected), 0);
  const CloudFile got = loadCloudFile(path);
  ASSERT_EQ(got.cloud.size(), expected.size());
  EXPECT_EQ(got.cloud.width, expected.width);
  EXPECT_EQ(got.cloud.height, expected.height);
  EXPECT_EQ(got.cloud.is_dense, false);
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const auto& a = got.cloud[i];
    const auto& b = expected[i];
    for (int k = 0; k < 3; ++k) {
      const float va = a.data[k], vb = b.data[k];
      if (std::isnan(vb)) {
        EXPECT_TRUE(std::isnan(va)) << path << " point " << i;
      } else {
        EXPECT_EQ(va, vb) << path << " point " << i;
      }
    }
  }
  EXPECT_NEAR((got.cloud.sensor_origin_ - expected.sensor_origin_).norm(), 0.f, 1e-6f);
  EXPECT_NEAR(got.cloud.sensor_orientation_.angularDistance(expected.sensor_orientation_), 0.f,
              1e-5f);
}

std::string header(const std::string& data, int points, const std::string& fields = "x y z",
                   const std::string& size = "4 4 4", const std::string& type = "F F F",
                   const std::string& count = "1 1 1") {
  std::ostringstream h;
  h << "VERSION .7\nFIELDS " << fields << "\nSIZE " << size << "\nTYPE " << type << "\nCOUNT "
    << count << "\nWIDTH " << points << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << points
    << "\nDATA " << data << "\n";
  return h.str();
}

}  // namespace

TEST(PcdReader, MatchesPclOnAsciiBinaryAndCompressed) {
  const auto c = sampleCloud(3);
  pcl::PCDWriter w;
  ASSERT_EQ(w.writeASCII(tmpPath("a.pcd"), c, 9), 0);
  ASSERT_EQ(w.writeBinary(tmpPath("b.pcd"), c), 0);
  ASSERT_EQ(w.writeBinaryCompressed(tmpPath("c.pcd"), c), 0);
  expectSameAsPcl(tmpPath("a.pcd"));
  expectSameAsPcl(tmpPath("b.pcd"));
  expectSameAsPcl(tmpPath("c.pcd"));
}

TEST(PcdReader, CompressedLargeCloudWithRepeatsMatchesPcl) {
  // Long runs of equal bytes exercise LZF's back references (overlapping copies).
  pcl::PointCloud<pcl::PointXYZ> c;
  for (int i = 0; i < 20000; ++i) c.push_back(pcl::PointXYZ(1.f, 2.f, static_cast<float>(i / 997)));
  pcl::PCDWriter w;
  ASSERT_EQ(w.writeBinaryCompressed(tmpPath("runs.pcd"), c), 0);
  const Cloud got = loadCloud(tmpPath("runs.pcd"));
  ASSERT_EQ(got.size(), c.size());
  for (std::size_t i = 0; i < c.size(); i += 101) EXPECT_EQ(got[i].z, c[i].z);
}

TEST(PcdReader, DoubleCoordinatesAndPaddingFields) {
  // x, y, z stored as doubles after an integer label and a 3-element padding field.
  const std::string path = tmpPath("double.pcd");
  {
    std::ofstream f(path, std::ios::binary);
    f << header("binary", 2, "label x y z _", "4 8 8 8 1", "U F F F U", "1 1 1 1 3");
    for (int i = 0; i < 2; ++i) {
      const std::uint32_t label = 9;
      const double xyz[3] = {1.5 + i, -2.25, 1e-3 * i};
      const char pad[3] = {0, 0, 0};
      f.write(reinterpret_cast<const char*>(&label), 4);
      f.write(reinterpret_cast<const char*>(xyz), 24);
      f.write(pad, 3);
    }
  }
  const Cloud c = loadCloud(path);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_FLOAT_EQ(c[1].x, 2.5f);
  EXPECT_FLOAT_EQ(c[1].y, -2.25f);
  EXPECT_FLOAT_EQ(c[1].z, 1e-3f);
}

TEST(PcdReader, HeaderBodyMismatchesGiveClearErrors) {
  const std::string bin = tmpPath("short_binary.pcd");
  std::ofstream(bin, std::ios::binary) << header("binary", 4) << std::string(40, 'a');
  EXPECT_NE(errorOf(bin).find("truncated binary"), std::string::npos);

  // The fuzz finding: a header line after DATA belongs to the body, which is too short.
  const std::string columns = tmpPath("columns.pcd");
  std::ofstream(columns, std::ios::binary) << header("binary", 2, "/ y z") << "COLUMNS@";
  EXPECT_NE(errorOf(columns).find("x, y, z"), std::string::npos);

  const std::string huge = tmpPath("huge.pcd");
  std::ofstream(huge) << header("ascii", 2000000000) << "1 2 3\n";
  EXPECT_NE(errorOf(huge).find("truncated ascii"), std::string::npos);

  const std::string lzf = tmpPath("bad_lzf.pcd");
  {
    std::ofstream f(lzf, std::ios::binary);
    f << header("binary_compressed", 2);
    const std::uint32_t sizes[2] = {4, 24};
    f.write(reinterpret_cast<const char*>(sizes), 8);
    f.write("\xe0\xff\xff\xff", 4);  // a back reference before the start of the output
  }
  EXPECT_NE(errorOf(lzf).find("bad LZF"), std::string::npos);

  const std::string expands = tmpPath("expands.pcd");
  {
    std::ofstream f(expands, std::ios::binary);
    f << header("binary_compressed", 2);
    const std::uint32_t sizes[2] = {4, 4000};
    f.write(reinterpret_cast<const char*>(sizes), 8);
    f.write(
        "\x03"
        "abc",
        4);  // a literal run of 4 bytes (not the escape \x03abc)
  }
  EXPECT_NE(errorOf(expands).find("expands to 4000 bytes"), std::string::npos);

  const std::string viewpoint = tmpPath("viewpoint.pcd");
  std::ofstream(viewpoint) << "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                              "WIDTH 1\nHEIGHT 1\nVIEWPOINT 0 0 nan 1 0 0 0\nPOINTS 1\n"
                              "DATA ascii\n1 2 3\n";
  EXPECT_NE(errorOf(viewpoint).find("VIEWPOINT"), std::string::npos);

  const std::string sides = tmpPath("sides.pcd");
  std::ofstream(sides) << "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                          "WIDTH 4294967295\nHEIGHT 4294967295\nPOINTS 1\nDATA ascii\n1 2 3\n";
  EXPECT_NE(errorOf(sides).find("too many points"), std::string::npos);

  const std::string integer_xyz = tmpPath("integer.pcd");
  std::ofstream(integer_xyz) << header("ascii", 1, "x y z", "4 4 4", "I I I") << "1 2 3\n";
  EXPECT_NE(errorOf(integer_xyz).find("float x, y, z"), std::string::npos);
}
