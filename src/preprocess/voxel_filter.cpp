#include "novelty_detection/preprocess/voxel_filter.h"

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <unordered_map>
#include <vector>

#include "novelty_detection/preprocess/input_check.h"

namespace novelty_detection {
namespace {

struct VoxelKey {
  std::int64_t x, y, z;
  bool operator==(const VoxelKey& o) const { return x == o.x && y == o.y && z == o.z; }
};

struct VoxelHash {
  std::size_t operator()(const VoxelKey& k) const {
    std::uint64_t h = static_cast<std::uint64_t>(k.x) * 0x9E3779B97F4A7C15ull;
    h ^= static_cast<std::uint64_t>(k.y) * 0xC2B2AE3D27D4EB4Full + (h << 6) + (h >> 2);
    h ^= static_cast<std::uint64_t>(k.z) * 0x165667B19E3779F9ull + (h << 6) + (h >> 2);
    return static_cast<std::size_t>(h);
  }
};

}  // namespace

Cloud voxelDownsample(const Cloud& cloud, double leaf_m) {
  if (!std::isfinite(leaf_m) || leaf_m < 1e-3)
    throw std::invalid_argument("voxel size must be at least 0.001 m");
  // |coordinate| <= kMaxCoordinateM and leaf >= 1 mm: indices stay below 1e8.
  std::unordered_map<VoxelKey, std::size_t, VoxelHash> voxel_of;
  struct Sum {
    double x = 0, y = 0, z = 0;
    std::size_t n = 0;
  };
  std::vector<Sum> sums;
  voxel_of.reserve(cloud.size());
  for (const PointT& p : cloud) {
    if (!usablePoint(p)) continue;
    const VoxelKey key{static_cast<std::int64_t>(std::floor(p.x / leaf_m)),
                       static_cast<std::int64_t>(std::floor(p.y / leaf_m)),
                       static_cast<std::int64_t>(std::floor(p.z / leaf_m))};
    const auto [it, added] = voxel_of.emplace(key, sums.size());
    if (added) sums.emplace_back();
    Sum& s = sums[it->second];
    s.x += p.x;
    s.y += p.y;
    s.z += p.z;
    ++s.n;
  }
  Cloud out;
  out.reserve(sums.size());
  for (const Sum& s : sums) {
    const double n = static_cast<double>(s.n);
    out.push_back(PointT(static_cast<float>(s.x / n), static_cast<float>(s.y / n),
                         static_cast<float>(s.z / n)));
  }
  out.sensor_origin_ = cloud.sensor_origin_;
  out.sensor_orientation_ = cloud.sensor_orientation_;
  return out;
}

}  // namespace novelty_detection
