// Shared by the real-scan tests: where the data set is, and the real pairs as the package
// takes them (sensor origins stated, the current sweep put into the reference's frame).
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "novelty_detection/alignment/alignment.h"
#include "novelty_detection/io/cloud_io.h"
#include "novelty_detection/pipeline.h"
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

inline fs::path roomDir() { return dataDir() / "pcl_room_scan"; }

/// The odometry guess that comes with the room scans: room_scan2 into room_scan1's frame,
/// 0.6931 rad about +z, then (1.79387, 0.720047, 0). About 0.7 m off.
inline Eigen::Isometry3d roomOdometryGuess() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translate(Eigen::Vector3d(1.79387, 0.720047, 0.0));
  T.rotate(Eigen::AngleAxisd(0.6931, Eigen::Vector3d::UnitZ()));
  return T;
}

/// The registration of room_scan2 into room_scan1's frame: from the odometry guess, PCL's NDT
/// (0.2 m voxels, resolution 1 m, step 0.1, epsilon 0.01, 35 iterations) and then generalized
/// ICP on 5 cm voxels of both scans with correspondence distances 0.3, 0.1 and 0.05 m
/// (test_room_scans.cpp, RoomScans.RegistrationIsReproduced, computes it again).
inline Eigen::Isometry3d roomTransform() {
  Eigen::Matrix4d m;
  m << 0.757126, -0.652778, 0.025317, 1.963146, 0.652634, 0.757530, 0.014751, 0.054038, -0.028807,
      0.005354, 0.999571, 0.024055, 0, 0, 0, 1;
  Eigen::Isometry3d T(m);
  T.linear() = Eigen::Quaterniond(T.linear()).normalized().toRotationMatrix();
  return T;
}

/// The room pair as it comes (every point stored twice, the robot's returns below the
/// sensor), each scan in its sensor frame (origin (0,0,0) stated), room_scan2 moved into
/// room_scan1's frame with roomTransform().
inline Pair roomPair() {
  Pair p;
  p.reference = loadCloud((roomDir() / "room_scan1.pcd").string());
  p.current = loadCloud((roomDir() / "room_scan2.pcd").string());
  setSensorOrigin(p.reference, Eigen::Vector3f::Zero());
  setSensorOrigin(p.current, Eigen::Vector3f::Zero());
  p.current = transformCloud(p.current, roomTransform());
  return p;
}

/// With NOVELTY_REAL_OUT set, writes the pair and its labels there for scripts/plot_flags.py:
/// "o x y z" per sensor origin (reference, current), "r x y z" per reference point and
/// "c x y z label" per current point (finite points only).
inline void writeFlags(const std::string& name, const Cloud& ref, const Cloud& cur,
                       const std::vector<int>& labels) {
  const char* dir = std::getenv("NOVELTY_REAL_OUT");
  if (!dir || !*dir) return;
  fs::create_directories(dir);
  std::FILE* f = std::fopen((fs::path(dir) / name).string().c_str(), "w");
  ASSERT_NE(f, nullptr) << "cannot write into NOVELTY_REAL_OUT=" << dir;
  for (const Cloud* c : {&ref, &cur})
    std::fprintf(f, "o %.4f %.4f %.4f\n", c->sensor_origin_.x(), c->sensor_origin_.y(),
                 c->sensor_origin_.z());
  for (const auto& p : ref)
    if (std::isfinite(p.x)) std::fprintf(f, "r %.4f %.4f %.4f\n", p.x, p.y, p.z);
  for (std::size_t i = 0; i < cur.size(); ++i)
    if (std::isfinite(cur[i].x))
      std::fprintf(f, "c %.4f %.4f %.4f %d\n", cur[i].x, cur[i].y, cur[i].z, labels[i]);
  std::fclose(f);
}

/// Runs an unchanged real pair with the defaults (superquadrics off) and `up`, prints its row
/// of the real-data table ("| <name> | <how>, up <up> | ... |") and its segments, and checks
/// the bar for an unchanged pair: at most 1.5 % of the current points novel and no segment
/// with a quarter or more of its points within 0.5 m of the current sensor (the robot).
/// With `flags_file` and NOVELTY_REAL_OUT set, writes the labels for scripts/plot_flags.py.
inline Result expectUnchangedPairFlagsLittle(const Pair& pair, const std::string& name,
                                             const std::string& how, const std::string& up,
                                             const std::string& flags_file) {
  const Cloud& cur = pair.current;
  Params p;
  p.preprocess.up = up;
  p.superquadric.enabled = false;
  Pipeline pipeline(p);
  pipeline.setReference(pair.reference);
  const Result r = pipeline.detect(cur);
  std::size_t novel = 0, near_sensor = 0;
  const Eigen::Vector3f origin = pair.currentOrigin();
  for (std::size_t i = 0; i < r.labels.size(); ++i) {
    if (r.labels[i] == 0) continue;
    ++novel;
    near_sensor += (cur[i].getVector3fMap() - origin).norm() < 1.0f;
  }
  const double share = static_cast<double>(novel) / cur.size();
  std::size_t self_returns = 0;
  for (const auto& [stage, n] : r.point_counts)
    if (stage == "self_returns") self_returns = n;
  std::printf(
      "| %s | %s, up %s | %.2f %% of %zu points novel, %zu within 1 m of the sensor; %zu "
      "segments; %zu points dropped as the robot's own returns; up (%.2f, %.2f, %.2f) %s; "
      "floor %s |\n",
      name.c_str(), how.c_str(), up.c_str(), 100.0 * share, cur.size(), near_sensor,
      r.segments.size(), self_returns, r.up.x(), r.up.y(), r.up.z(), r.up_source.c_str(),
      r.floor_found ? "found" : "none");
  for (const auto& [stage, n] : r.point_counts) std::printf("  %s %zu\n", stage.c_str(), n);
  for (const Segment& seg : r.segments)
    std::printf("  segment %d: %zu points at (%.2f, %.2f, %.2f), %.2f m from the sensor\n", seg.id,
                seg.indices.size(), seg.centroid.x(), seg.centroid.y(), seg.centroid.z(),
                (seg.centroid - origin.cast<double>()).norm());
  EXPECT_LE(share, 0.015) << name << ", up " << up;
  for (const Segment& seg : r.segments) {
    std::size_t on_robot = 0;
    for (int i : seg.indices) on_robot += (cur[i].getVector3fMap() - origin).norm() < 0.5f;
    EXPECT_LT(on_robot, seg.indices.size() / 4)
        << name << ", up " << up << ": segment " << seg.id << " is on the robot";
  }
  if (!flags_file.empty()) writeFlags(flags_file, pair.reference, cur, r.labels);
  return r;
}

}  // namespace real_data
}  // namespace novelty_detection
