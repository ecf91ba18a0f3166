// Decodes fuzz bytes into a sensor_msgs::PointCloud2 (shared by the libFuzzer target and the
// regression test that replays the kept inputs). Layout, little-endian, missing bytes read
// as 0:
//   u32 width, u32 height, u32 point_step, u32 row_step, u8 is_bigendian, u8 n_fields,
//   then n_fields % 9 records of { u8 name_index, u32 offset, u8 datatype, u32 count },
//   then the rest is msg.data.
// name_index % 8 picks from {x, y, z, intensity, label, "", X, xyz}.
#pragma once

#include <sensor_msgs/PointCloud2.h>

#include <cstdint>
#include <cstring>

namespace novelty_detection {
namespace fuzz {

class ByteReader {
 public:
  ByteReader(const std::uint8_t* p, std::size_t n) : p_(p), n_(n) {}
  template <typename T>
  T get() {
    T v{};
    const std::size_t k = n_ < sizeof(T) ? n_ : sizeof(T);
    std::memcpy(&v, p_, k);
    p_ += k;
    n_ -= k;
    return v;
  }
  const std::uint8_t* rest() const { return p_; }
  std::size_t remaining() const { return n_; }

 private:
  const std::uint8_t* p_;
  std::size_t n_;
};

inline sensor_msgs::PointCloud2 pointCloud2FromBytes(const std::uint8_t* data, std::size_t size) {
  static const char* const kNames[] = {"x", "y", "z", "intensity", "label", "", "X", "xyz"};
  ByteReader in(data, size);
  sensor_msgs::PointCloud2 msg;
  msg.width = in.get<std::uint32_t>();
  msg.height = in.get<std::uint32_t>();
  msg.point_step = in.get<std::uint32_t>();
  msg.row_step = in.get<std::uint32_t>();
  msg.is_bigendian = in.get<std::uint8_t>() & 1;
  const unsigned n_fields = in.get<std::uint8_t>() % 9;
  for (unsigned i = 0; i < n_fields; ++i) {
    sensor_msgs::PointField f;
    f.name = kNames[in.get<std::uint8_t>() % 8];
    f.offset = in.get<std::uint32_t>();
    f.datatype = in.get<std::uint8_t>();
    f.count = in.get<std::uint32_t>();
    msg.fields.push_back(f);
  }
  msg.data.assign(in.rest(), in.rest() + in.remaining());
  msg.is_dense = false;
  return msg;
}

}  // namespace fuzz
}  // namespace novelty_detection
