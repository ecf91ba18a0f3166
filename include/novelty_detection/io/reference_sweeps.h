// A reference map on disk: one cloud file, or a directory of sweeps each with its sensor
// pose (a route map). ROS-free.
//
//   REF.pcd | REF.ply   one cloud; its PCD VIEWPOINT, when not the identity, is its one
//                       sensor origin (the visibility rules are off without one)
//   REF_DIR/            every *.pcd in it (name order), each one sweep in the map frame
//                       whose VIEWPOINT is the pose of the sensor that took it, stated even
//                       when it is the identity (a sweep taken at the map's origin); other
//                       files (caches, notes) are ignored
//
// The sweeps are merged into one cloud, and ReferenceViews (types.h) keeps which sweep each
// point came from and where that sweep was seen from: what any of them saw through counts
// as free space (visibility.h).
#pragma once

#include <string>
#include <vector>

#include "novelty_detection/io/cloud_io.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

struct ReferenceMap {
  Cloud cloud;                     ///< all sweeps, merged (one row)
  ReferenceViews views;            ///< per sweep its origin; empty for a single file
  std::vector<std::string> files;  ///< what was read, in order
};

/// Whether `path` names a directory.
bool isDirectory(const std::string& path);

/// Whether `path` ends in .pcd (any case): a single-file reference rather than a directory.
bool hasPcdExtension(const std::string& path);

/// Loads a reference file or directory (see the header comment). `limits` bounds the total
/// number of points, checked on each file's header before its body is read. Throws
/// std::runtime_error naming the path and the problem: no such file or directory, a
/// directory without *.pcd, more sweeps than a reference holds (kMaxReferenceSweeps), or any
/// refusal of loadCloudFile.
ReferenceMap loadReference(const std::string& path, const LoadLimits& limits = {});

/// Most sweeps one reference directory may hold.
constexpr std::size_t kMaxReferenceSweeps = 10000;

/// Writes `sweeps` (each in the map frame with the pose of its sensor) as a reference
/// directory `dir`: dir/sweep_0000.pcd, ... (binary, VIEWPOINT = pose). The sweeps are
/// written into a new directory beside `dir` and it replaces `dir` only when complete: a
/// failed save leaves an existing `dir` as it was. An existing `dir` is replaced only when
/// it holds nothing but sweep_*.pcd files (a reference this function wrote). Throws
/// std::runtime_error naming the path, the step and the system's reason on failure.
void saveReferenceSweeps(const std::string& dir, const std::vector<CloudFile>& sweeps);

}  // namespace novelty_detection
