// PointCloud2 layouts that lie about their size, and the fuzz inputs kept under
// test/fuzz/corpus/pointcloud2: each converts with width * height points or is refused with
// std::invalid_argument, before any allocation sized by the header.
#include <gtest/gtest.h>

#include <dirent.h>

#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

#include "../fuzz/pointcloud2_from_bytes.h"
#include "novelty_detection/ros/conversions.h"

using namespace novelty_detection;
using sensor_msgs::PointCloud2;
using sensor_msgs::PointField;

namespace {

PointCloud2 xyzHeader(std::uint32_t width, std::uint32_t height) {
  PointCloud2 msg;
  for (const char* name : {"x", "y", "z"}) {
    PointField f;
    f.name = name;
    f.offset = static_cast<std::uint32_t>(4 * msg.fields.size());
    f.datatype = PointField::FLOAT32;
    f.count = 1;
    msg.fields.push_back(f);
  }
  msg.width = width;
  msg.height = height;
  msg.point_step = 12;
  msg.row_step = 12 * width;
  return msg;
}

std::string errorOf(const PointCloud2& msg) {
  try {
    fromPointCloud2(msg);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(PointCloud2BadInput, TenMillionPointHeaderWithoutDataIsRefused) {
  // A header announcing 10M points (120 MB) over 12 bytes of data: refused by size.
  PointCloud2 msg = xyzHeader(10000000, 1);
  msg.data.resize(12);
  EXPECT_NE(errorOf(msg).find("layout needs 120000000"), std::string::npos) << errorOf(msg);
  // The largest header the fields can express must not overflow the size arithmetic.
  msg = xyzHeader(0xffffffffu, 0xffffffffu);
  msg.row_step = 0xffffffffu;
  EXPECT_NE(errorOf(msg).find("row_step"), std::string::npos) << errorOf(msg);
  msg.point_step = 1;
  msg.fields.resize(1);
  msg.fields[0].offset = 0;
  EXPECT_NE(errorOf(msg).find("does not fit in point_step"), std::string::npos);
}

TEST(PointCloud2BadInput, DegenerateLayoutsAreRefusedByName) {
  PointCloud2 msg = xyzHeader(2, 1);
  msg.data.resize(24);
  msg.point_step = 0;
  msg.row_step = 0;
  EXPECT_FALSE(errorOf(msg).empty());
  msg = xyzHeader(2, 1);
  msg.data.resize(24);
  msg.fields[2].count = 0;
  EXPECT_NE(errorOf(msg).find("'z' has count 0"), std::string::npos) << errorOf(msg);
  msg = xyzHeader(2, 1);
  msg.data.resize(24);
  msg.fields[0].offset = 0xfffffffeu;  // offset + 4 overflows 32 bits
  EXPECT_NE(errorOf(msg).find("does not fit in point_step"), std::string::npos) << errorOf(msg);
  // Zero points: an empty cloud whatever the rest says.
  msg = xyzHeader(0, 7);
  EXPECT_EQ(fromPointCloud2(msg).size(), 0u);
}

TEST(PointCloud2BadInput, KeptFuzzInputsConvertOrAreRefused) {
  // NOVELTY_TEST_DATA_DIR is <package>/test/data (which need not exist): its parent is test/.
  const std::string data_dir = NOVELTY_TEST_DATA_DIR;
  const std::string dir = data_dir.substr(0, data_dir.rfind('/')) + "/fuzz/corpus/pointcloud2";
  DIR* d = opendir(dir.c_str());
  ASSERT_NE(d, nullptr) << dir;
  int files = 0, converted = 0;
  while (dirent* e = readdir(d)) {
    if (e->d_name[0] == '.') continue;
    std::ifstream in(dir + "/" + e->d_name, std::ios::binary);
    const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                          std::istreambuf_iterator<char>());
    const PointCloud2 msg = fuzz::pointCloud2FromBytes(bytes.data(), bytes.size());
    ++files;
    try {
      const Cloud c = fromPointCloud2(msg);
      EXPECT_EQ(c.size(), static_cast<std::size_t>(msg.width) * msg.height) << e->d_name;
      ++converted;
    } catch (const std::invalid_argument&) {
    }
  }
  closedir(d);
  EXPECT_GE(files, 8);
  // The seeds include valid dense, organised/padded, big-endian and empty layouts.
  EXPECT_GE(converted, 4);
}
