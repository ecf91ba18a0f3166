#include "novelty_detection/ros/conversions.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>

#include "novelty_detection/ros/result_messages.h"

namespace novelty_detection {
namespace {

// rviz's RGB8 colour: 0x00RRGGBB in the bytes of a FLOAT32 field named rgb.
std::uint32_t packedColour(int label) {
  if (label <= 0) return 0x999999u;  // not novel: grey
  const std_msgs::ColorRGBA c = segmentColour(label);
  auto byte = [](float v) {
    return static_cast<std::uint32_t>(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f));
  };
  return (byte(c.r) << 16) | (byte(c.g) << 8) | byte(c.b);
}

bool hostIsBigEndian() {
  const std::uint16_t one = 1;
  std::uint8_t first = 0;
  std::memcpy(&first, &one, 1);
  return first == 0;
}

const sensor_msgs::PointField& requireFloatField(const sensor_msgs::PointCloud2& msg,
                                                 const std::string& name) {
  for (const auto& f : msg.fields) {
    if (f.name != name) continue;
    if (f.datatype != sensor_msgs::PointField::FLOAT32) {
      throw std::invalid_argument("PointCloud2 field '" + name + "' has datatype " +
                                  std::to_string(f.datatype) + ", expected FLOAT32 (7)");
    }
    if (f.count == 0) {
      throw std::invalid_argument("PointCloud2 field '" + name + "' has count 0");
    }
    if (static_cast<std::uint64_t>(f.offset) + 4 > msg.point_step) {
      throw std::invalid_argument("PointCloud2 field '" + name + "' at offset " +
                                  std::to_string(f.offset) + " does not fit in point_step " +
                                  std::to_string(msg.point_step));
    }
    return f;
  }
  throw std::invalid_argument("PointCloud2 has no '" + name + "' field");
}

float readFloat(const std::uint8_t* p, bool swap) {
  std::uint8_t bytes[4];
  std::memcpy(bytes, p, 4);
  if (swap) {
    std::swap(bytes[0], bytes[3]);
    std::swap(bytes[1], bytes[2]);
  }
  float v;
  std::memcpy(&v, bytes, 4);
  return v;
}

sensor_msgs::PointField makeField(const char* name, std::uint32_t offset, std::uint8_t type) {
  sensor_msgs::PointField f;
  f.name = name;
  f.offset = offset;
  f.datatype = type;
  f.count = 1;
  return f;
}

}  // namespace

Cloud fromPointCloud2(const sensor_msgs::PointCloud2& msg) {
  const auto& fx = requireFloatField(msg, "x");
  const auto& fy = requireFloatField(msg, "y");
  const auto& fz = requireFloatField(msg, "z");
  const std::uint64_t width = msg.width, height = msg.height;
  const std::uint64_t n = width * height;
  Cloud cloud;
  cloud.is_dense = false;
  if (n == 0) return cloud;
  if (msg.point_step == 0) throw std::invalid_argument("PointCloud2 has point_step 0");
  const std::uint64_t min_row = width * msg.point_step;
  if (msg.row_step < min_row) {
    throw std::invalid_argument("PointCloud2 row_step " + std::to_string(msg.row_step) +
                                " is smaller than width * point_step = " + std::to_string(min_row));
  }
  // The last row only needs width * point_step bytes, but a conforming message carries
  // height * row_step; accept the shorter form, refuse anything shorter than that.
  const std::uint64_t needed = (height - 1) * msg.row_step + min_row;
  if (msg.data.size() < needed) {
    throw std::invalid_argument("PointCloud2 data has " + std::to_string(msg.data.size()) +
                                " bytes, its width " + std::to_string(width) + " x height " +
                                std::to_string(height) + " layout needs " + std::to_string(needed));
  }
  const bool swap = static_cast<bool>(msg.is_bigendian) != hostIsBigEndian();
  cloud.resize(n);
  std::size_t k = 0;
  for (std::uint64_t r = 0; r < height; ++r) {
    const std::uint8_t* row = msg.data.data() + r * msg.row_step;
    for (std::uint64_t c = 0; c < width; ++c, ++k) {
      const std::uint8_t* p = row + c * msg.point_step;
      PointT& q = cloud[k];
      q.x = readFloat(p + fx.offset, swap);
      q.y = readFloat(p + fy.offset, swap);
      q.z = readFloat(p + fz.offset, swap);
    }
  }
  // Keep the input order flat: labels are indexed like the message's points.
  cloud.width = static_cast<std::uint32_t>(n);
  cloud.height = 1;
  return cloud;
}

sensor_msgs::PointCloud2 toLabelledPointCloud2(const Cloud& cloud, const std::vector<int>& labels,
                                               const std_msgs::Header& header, bool only_labelled) {
  if (labels.size() != cloud.size()) {
    throw std::invalid_argument("labels (" + std::to_string(labels.size()) +
                                ") do not match the cloud (" + std::to_string(cloud.size()) +
                                " points)");
  }
  sensor_msgs::PointCloud2 out;
  out.header = header;
  out.fields = {makeField("x", 0, sensor_msgs::PointField::FLOAT32),
                makeField("y", 4, sensor_msgs::PointField::FLOAT32),
                makeField("z", 8, sensor_msgs::PointField::FLOAT32),
                makeField("label", 12, sensor_msgs::PointField::UINT32),
                makeField("rgb", 16, sensor_msgs::PointField::FLOAT32)};
  out.point_step = 20;
  out.is_bigendian = hostIsBigEndian();
  std::size_t count = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!only_labelled || labels[i] > 0) ++count;
  }
  out.height = 1;
  out.width = static_cast<std::uint32_t>(count);
  out.row_step = out.point_step * out.width;
  out.data.resize(out.row_step);
  bool dense = true;
  std::uint8_t* p = out.data.data();
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (only_labelled && labels[i] <= 0) continue;
    const PointT& q = cloud[i];
    const std::uint32_t label = labels[i] > 0 ? static_cast<std::uint32_t>(labels[i]) : 0u;
    std::memcpy(p + 0, &q.x, 4);
    std::memcpy(p + 4, &q.y, 4);
    std::memcpy(p + 8, &q.z, 4);
    std::memcpy(p + 12, &label, 4);
    const std::uint32_t rgb = packedColour(labels[i]);
    std::memcpy(p + 16, &rgb, 4);
    dense = dense && std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z);
    p += out.point_step;
  }
  out.is_dense = dense;
  return out;
}

Cloud withViewpoint(const CloudFile& file) {
  Cloud cloud = file.cloud;
  cloud.sensor_origin_.head<3>() = file.T_frame_sensor.translation().cast<float>();
  cloud.sensor_origin_[3] = 0.0f;
  cloud.sensor_orientation_ = Eigen::Quaternionf(file.T_frame_sensor.linear().cast<float>());
  return cloud;
}

Eigen::Isometry3d viewpointOf(const Cloud& cloud) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = cloud.sensor_origin_.head<3>().cast<double>();
  T.linear() = cloud.sensor_orientation_.normalized().toRotationMatrix().cast<double>();
  return T;
}

sensor_msgs::PointCloud2 toPointCloud2(const Cloud& cloud, const std_msgs::Header& header) {
  sensor_msgs::PointCloud2 out;
  out.header = header;
  out.fields = {makeField("x", 0, sensor_msgs::PointField::FLOAT32),
                makeField("y", 4, sensor_msgs::PointField::FLOAT32),
                makeField("z", 8, sensor_msgs::PointField::FLOAT32)};
  out.point_step = 12;
  out.is_bigendian = hostIsBigEndian();
  const bool organised =
      cloud.height > 1 && static_cast<std::size_t>(cloud.width) * cloud.height == cloud.size();
  out.height = organised ? cloud.height : 1;
  out.width = organised ? cloud.width : static_cast<std::uint32_t>(cloud.size());
  out.row_step = out.point_step * out.width;
  out.data.resize(static_cast<std::size_t>(out.row_step) * out.height);
  bool dense = true;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const PointT& q = cloud[i];
    std::memcpy(out.data.data() + i * 12 + 0, &q.x, 4);
    std::memcpy(out.data.data() + i * 12 + 4, &q.y, 4);
    std::memcpy(out.data.data() + i * 12 + 8, &q.z, 4);
    dense = dense && std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z);
  }
  out.is_dense = dense;
  return out;
}

}  // namespace novelty_detection
