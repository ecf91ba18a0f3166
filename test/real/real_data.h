// Shared by the real-scan tests: where the data set is, and the real pairs as the package
// takes them (sensor origins stated, the current sweep put into the reference's frame).
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "novelty_detection/alignment/alignment.h"
#include "novelty_detection/io/cloud_io.h"
#include "novelty_detection/types.h"

namespace novelty_detection {
namespace real_data {

namespace fs = std::filesystem;

/// The directory of the real-scan folders (NOVELTY_REAL_DATA), or empty.
inline fs::path dataDir() {
  const char* d = std::getenv("NOVELTY_REAL_DATA");
  return d ? fs::path(d) : fs::path();
}

#define REQUIRE_DATA(path)                                                                 \
  if (::novelty_detection::real_data::dataDir().empty() || !std::filesystem::exists(path)) \
  GTEST_SKIP() << "real data not found (" << (path)                                        \
               << "); set NOVELTY_REAL_DATA to the "                                       \
                  "directory that holds the real-scan folders"

/// A reference / current pair in one frame, each with its sensor origin stated.
struct Pair {
  Cloud reference, current;
  Eigen::Vector3f currentOrigin() const { return current.sensor_origin_.head<3>(); }
};

/// The published registration of the ETH pair: cloud_1 into cloud_0's frame.
inline Eigen::Isometry3d ethTransform() {
  Eigen::Matrix4d m;
  m << 0.993552, -0.113149, 0.00713103, 0.60831, 0.113181, 0.993565, -0.00425984, -0.00387758,
      -0.00660312, 0.00503951, 0.999965, 0.0107267, 0, 0, 0, 1;
  return Eigen::Isometry3d(m);
}

inline fs::path ethDir() { return dataDir() / "eth_apartment_tilting_hokuyo"; }

/// The ETH apartment pair: each cloud in its sensor frame (origin (0,0,0) stated), cloud_1
/// moved into cloud_0's frame with the published registration (its origin moves with it).
inline Pair ethPair() {
  Pair p;
  p.reference = loadCloud((ethDir() / "cloud_0.pcd").string());
  p.current = loadCloud((ethDir() / "cloud_1.pcd").string());
  setSensorOrigin(p.reference, Eigen::Vector3f::Zero());
  setSensorOrigin(p.current, Eigen::Vector3f::Zero());
  p.current = transformCloud(p.current, ethTransform());
  return p;
}

}  // namespace real_data
}  // namespace novelty_detection
