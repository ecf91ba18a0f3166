// PointCloud2 <-> Cloud: any layout with FLOAT32 x, y, z converts in input order; broken
// messages are refused with a message naming the problem.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include "novelty_detection/ros/conversions.h"
#include "novelty_detection/ros/result_messages.h"

using novelty_detection::Cloud;
using novelty_detection::fromPointCloud2;
using novelty_detection::toLabelledPointCloud2;
using sensor_msgs::PointCloud2;
using sensor_msgs::PointField;

namespace {

PointField field(const std::string& name, uint32_t offset, uint8_t type = PointField::FLOAT32) {
  PointField f;
  f.name = name;
  f.offset = offset;
  f.datatype = type;
  f.count = 1;
  return f;
}

void putFloat(PointCloud2& msg, std::size_t byte, float v, bool big_endian) {
  uint8_t b[4];
  std::memcpy(b, &v, 4);
  if (big_endian) {
    std::swap(b[0], b[3]);
    std::swap(b[1], b[2]);
  }
  std::memcpy(msg.data.data() + byte, b, 4);
}

// Point i has coordinates (i, 10 i, 100 i) (+0.5 to exercise fractions).
float coord(int i, int axis) { return static_cast<float>((i + 0.5) * std::pow(10.0, axis)); }

// An organised cloud with the fields in the order z, pad, x, intensity, y, padded rows.
PointCloud2 makeCloud(uint32_t width, uint32_t height, bool big_endian) {
  PointCloud2 msg;
  msg.width = width;
  msg.height = height;
  msg.fields = {field("z", 0), field("x", 8), field("intensity", 12), field("y", 16)};
  msg.point_step = 24;
  msg.row_step = width * msg.point_step + 8;  // row padding
  msg.is_bigendian = big_endian;
  msg.data.assign(static_cast<std::size_t>(msg.row_step) * height, 0xAB);
  int i = 0;
  for (uint32_t r = 0; r < height; ++r) {
    for (uint32_t c = 0; c < width; ++c, ++i) {
      const std::size_t base = r * msg.row_step + c * msg.point_step;
      putFloat(msg, base + 8, coord(i, 0), big_endian);
      putFloat(msg, base + 16, coord(i, 1), big_endian);
      putFloat(msg, base + 0, coord(i, 2), big_endian);
    }
  }
  return msg;
}

void expectThrowsWith(const PointCloud2& msg, const std::string& what) {
  try {
    fromPointCloud2(msg);
    FAIL() << "no exception, expected one mentioning '" << what << "'";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
  }
}

}  // namespace

TEST(Conversions, OrganisedPaddedLayoutKeepsRowMajorOrder) {
  for (bool big_endian : {false, true}) {
    const PointCloud2 msg = makeCloud(5, 3, big_endian);
    const Cloud cloud = fromPointCloud2(msg);
    ASSERT_EQ(cloud.size(), 15u);
    for (int i = 0; i < 15; ++i) {
      EXPECT_FLOAT_EQ(cloud[i].x, coord(i, 0)) << i << (big_endian ? " big" : " little");
      EXPECT_FLOAT_EQ(cloud[i].y, coord(i, 1)) << i;
      EXPECT_FLOAT_EQ(cloud[i].z, coord(i, 2)) << i;
    }
  }
}

TEST(Conversions, NanPointsAreKeptInPlace) {
  PointCloud2 msg = makeCloud(4, 1, false);
  putFloat(msg, 1 * msg.point_step + 8, std::numeric_limits<float>::quiet_NaN(), false);
  const Cloud cloud = fromPointCloud2(msg);
  ASSERT_EQ(cloud.size(), 4u);
  EXPECT_TRUE(std::isnan(cloud[1].x));
  EXPECT_FLOAT_EQ(cloud[2].x, coord(2, 0));
}

TEST(Conversions, EmptyCloudIsEmpty) {
  PointCloud2 msg = makeCloud(0, 0, false);
  EXPECT_TRUE(fromPointCloud2(msg).empty());
}

TEST(Conversions, RefusesMissingField) {
  PointCloud2 msg = makeCloud(2, 1, false);
  msg.fields.erase(msg.fields.begin() + 1);  // x
  expectThrowsWith(msg, "no 'x' field");
}

TEST(Conversions, RefusesWrongDatatype) {
  PointCloud2 msg = makeCloud(2, 1, false);
  msg.fields[3].datatype = PointField::FLOAT64;  // y
  expectThrowsWith(msg, "'y' has datatype 8");
}

TEST(Conversions, RefusesFieldPastPointStep) {
  PointCloud2 msg = makeCloud(2, 1, false);
  msg.fields[3].offset = 22;
  expectThrowsWith(msg, "does not fit in point_step");
}

TEST(Conversions, RefusesShortRowStep) {
  PointCloud2 msg = makeCloud(2, 2, false);
  msg.row_step = msg.width * msg.point_step - 1;
  expectThrowsWith(msg, "row_step");
}

TEST(Conversions, RefusesTruncatedData) {
  PointCloud2 msg = makeCloud(3, 2, false);
  msg.data.resize(msg.row_step + 3 * msg.point_step - 1);
  expectThrowsWith(msg, "bytes");
  msg.width = 100;  // width * height * point_step beyond the data
  msg.row_step = msg.width * msg.point_step;
  expectThrowsWith(msg, "bytes");
}

TEST(Conversions, LabelledCloudRoundTrips) {
  const Cloud cloud = fromPointCloud2(makeCloud(4, 2, false));
  const std::vector<int> labels = {0, 1, 0, 2, 2, 0, 0, 1};
  std_msgs::Header header;
  header.frame_id = "map";
  const PointCloud2 all = toLabelledPointCloud2(cloud, labels, header, false);
  EXPECT_EQ(all.width * all.height, 8u);
  const PointCloud2 novel = toLabelledPointCloud2(cloud, labels, header, true);
  ASSERT_EQ(novel.width * novel.height, 4u);
  const Cloud back = fromPointCloud2(novel);
  const int expected_index[] = {1, 3, 4, 7};
  for (int k = 0; k < 4; ++k) {
    EXPECT_FLOAT_EQ(back[k].x, cloud[expected_index[k]].x);
    uint32_t label;
    std::memcpy(&label, novel.data.data() + k * novel.point_step + 12, 4);
    EXPECT_EQ(static_cast<int>(label), labels[expected_index[k]]);
    // Each segment's points in its own colour, the colour of its superquadrics.
    uint32_t rgb;
    std::memcpy(&rgb, novel.data.data() + k * novel.point_step + 16, 4);
    const std_msgs::ColorRGBA c = novelty_detection::segmentColour(static_cast<int>(label));
    EXPECT_EQ(rgb >> 16, static_cast<uint32_t>(std::lround(c.r * 255)));
    EXPECT_EQ((rgb >> 8) & 0xff, static_cast<uint32_t>(std::lround(c.g * 255)));
    EXPECT_EQ(rgb & 0xff, static_cast<uint32_t>(std::lround(c.b * 255)));
  }
  ASSERT_EQ(novel.fields.size(), 5u);
  EXPECT_EQ(novel.fields[4].name, "rgb");
  EXPECT_EQ(novel.fields[4].offset, 16u);
  uint32_t grey;
  std::memcpy(&grey, all.data.data() + 0 * all.point_step + 16, 4);  // label 0
  EXPECT_EQ(grey, 0x999999u);
  uint32_t one, two;
  std::memcpy(&one, novel.data.data() + 0 * novel.point_step + 16, 4);
  std::memcpy(&two, novel.data.data() + 1 * novel.point_step + 16, 4);
  EXPECT_NE(one, two);  // segments 1 and 2 differ
  EXPECT_THROW(toLabelledPointCloud2(cloud, {1, 2}, header, false), std::invalid_argument);
}

TEST(Conversions, ViewpointRoundTrips) {
  novelty_detection::CloudFile file;
  file.cloud.push_back(novelty_detection::PointT(1, 2, 3));
  file.T_frame_sensor.translation() = Eigen::Vector3d(0.5, -1.0, 1.2);
  file.T_frame_sensor.linear() =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Cloud cloud = novelty_detection::withViewpoint(file);
  EXPECT_FLOAT_EQ(cloud.sensor_origin_[2], 1.2f);
  EXPECT_TRUE(novelty_detection::viewpointOf(cloud).isApprox(file.T_frame_sensor, 1e-6));
}
