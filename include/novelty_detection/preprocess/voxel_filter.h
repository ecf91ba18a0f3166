// Thinning a cloud to one point per voxel, safe on maps of any extent. ROS-free.
//
// PCL's VoxelGrid packs the three voxel indices into one 32-bit integer and, for a map
// longer than about 1290 voxels per axis (26 m at 2 cm across the three axes), gives up
// with "Integer indices would overflow" and returns the cloud unfiltered. Here each voxel
// is keyed by three 64-bit indices in a hash map, so every usable point (input_check.h)
// gets a voxel whatever the map's size.
#pragma once

#include "novelty_detection/types.h"

namespace novelty_detection {

/// One point per occupied voxel of edge `leaf_m`: the centroid of its points, in the order
/// the voxels are first met. Non-finite and out-of-range points are dropped. The sensor
/// pose is kept. Throws std::invalid_argument unless leaf_m is finite and at least 1 mm.
Cloud voxelDownsample(const Cloud& cloud, double leaf_m);

}  // namespace novelty_detection
