// libFuzzer target: a sensor_msgs::PointCloud2 decoded from the fuzz bytes (fields, offsets,
// datatypes, width/height/point_step/row_step, endianness, data; see pointcloud2_from_bytes.h)
// through fromPointCloud2(). Any outcome other than a cloud with width * height points or a
// std::invalid_argument (crash, sanitizer report, hang, other exception) is a finding.
#include <cstdint>
#include <cstdlib>
#include <stdexcept>

#include "novelty_detection/ros/conversions.h"
#include "pointcloud2_from_bytes.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const sensor_msgs::PointCloud2 msg = novelty_detection::fuzz::pointCloud2FromBytes(data, size);
  try {
    const novelty_detection::Cloud cloud = novelty_detection::fromPointCloud2(msg);
    const std::uint64_t expected = static_cast<std::uint64_t>(msg.width) * msg.height;
    if (cloud.size() != expected || cloud.width * cloud.height != cloud.size()) std::abort();
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
