// The usual voxel-difference change detector, as a baseline to compare novelty detection
// with: PCL's OctreePointCloudChangeDetector finds the points of one cloud in
// voxels the other cloud leaves empty, and Euclidean clustering groups them into
// segments. Run both ways it gives appearances (current points) and disappearances
// (reference points). ROS-free.
//
// It deliberately has no notion of viewpoint, visibility or localisation error: that is
// what it is a baseline for. Its settings are not detector parameters (params.h): they
// belong to the comparison and are documented in docs/evaluation.md.
#pragma once

#include <string>
#include <vector>

#include "novelty_detection/types.h"

namespace novelty_detection {

struct BaselineOptions {
  /// Octree voxel edge [m]; 0 = resolution_factor x the median nearest-neighbour spacing
  /// of the reference cloud (the voxels then scale with the sensor's sampling). The
  /// defaults (10x, 2x, 30) were chosen on six same-pose simulated scenes (seeds 2-7, a box
  /// and a person each), not on the viewpoint suite: the voxel must exceed the range noise
  /// and the clusters must bridge the tilt lines (0.12-0.20 m voxels on the viewpoint suite).
  double resolution_m = 0.0;
  double resolution_factor = 10.0;
  /// Euclidean clustering distance as a multiple of the voxel edge: points in touching
  /// new voxels join one segment.
  double cluster_tolerance_factor = 2.0;
  /// Smaller clusters are dropped as noise (label 0).
  int min_cluster_size = 30;

  /// Throws std::invalid_argument naming the bad field.
  void validate() const;
};

struct BaselineResult {
  /// One per current point: 0, or k > 0 the segment (k = 1 is the largest), as labels.txt.
  std::vector<int> labels;
  /// One per reference point: 0, or k > 0 a disappearance segment.
  std::vector<int> disappeared_labels;
  double resolution_m = 0.0;  ///< voxel edge used
  int segments = 0, disappeared_segments = 0;
};

/// Median distance from a point to its nearest neighbour, over up to max_samples evenly
/// spread finite points. 0 for fewer than two finite points.
double medianPointSpacing(const Cloud& cloud, std::size_t max_samples = 4000);

/// Points of `after` in octree voxels that hold no point of `before`, clustered; one label
/// per point of `after` (non-finite points get 0).
std::vector<int> voxelChangeLabels(const Cloud& before, const Cloud& after, double resolution_m,
                                   double cluster_tolerance_m, int min_cluster_size);

/// Both directions. Throws std::invalid_argument for bad options, or when the reference has
/// fewer than two finite points and no fixed resolution is given.
BaselineResult detectChangesBaseline(const Cloud& reference, const Cloud& current,
                                     const BaselineOptions& options = {});

/// Reads options from a YAML file with keys resolution_m, resolution_factor,
/// cluster_tolerance_factor, min_cluster_size (all optional; under a top-level `baseline:`
/// map or at the top level). Throws std::runtime_error naming the file and key.
BaselineOptions loadBaselineOptions(const std::string& path);

}  // namespace novelty_detection
