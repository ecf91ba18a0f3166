// Bounded fine alignment of the current sweep against the reference.
// ROS-free; PCL stays out of this header.
//
// Localisation is off by centimetres on a patrol robot, and a difference of clouds reads a
// shifted wall as novelty. Before comparison the sweep's pose is refined by a robust
// point-to-plane ICP on the static structure of the map:
//
// 1. Reference (once, when the reference is set): the map's points are binned in cubic cells
//    sized from the data (the cell of a typical point holds about plane_cell_points points);
//    a cell whose covariance is planar (l0 < planarity * l1, l1 >= planarity * l2) keeps a
//    plane, refitted twice on a +-3 noise slab gathered from the neighbouring cells (a cell's
//    faces cut the noise of a surface running near them and move its centroid). Planes
//    average the map's range noise; single scan lines and corners are skipped.
// 2. Sample: about sample_points points of the sweep, every k-th in input order (chosen
//    independently of their noise, unlike voxel centroids), each weighted by 1 / samples in
//    its voxel so near, dense parts do not dominate the rotation.
// 3. Gauss-Newton on r_i = n_i . (T p_i - c_i) over the pose increment (rotation about the
//    sample centroid, translation), each sample matched to the plane of its own cell, else
//    of the neighbouring cell with the nearest centroid. Robust: Tukey biweight with a scale
//    of robust_scale_factor robust sigmas (1.4826 MAD) of the residuals, at least
//    robust_scale_factor times the map's noise (median plane thickness); a correspondence
//    gate starts at twice the bound and shrinks by gate_shrink once the steps are small
//    against it. Changed objects, farther than that from every plane, get no weight.
// 4. Degeneracy (Zhang, Kaess, Singh, ICRA 2016): the normal-equation matrix, rotations scaled
//    by the sample radius, is eigen-decomposed; directions with an eigenvalue below
//    degeneracy_ratio times the largest (a corridor's axis) are not updated, so the pose
//    stays as given along them instead of drifting on noise.
// 5. Bounded: a correction moving the sensor origin by more than max_translation_m or
//    rotating by more than max_rotation_deg, an inlier share below min_inlier_fraction, fewer
//    than min_correspondences matches or no constrained direction is rejected: the sweep is
//    left as given and the reason reported.
#pragma once

#include <memory>

#include "novelty_detection/params.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

/// The reference planes the sweep is aligned to (built once per reference).
class AlignmentReference {
 public:
  AlignmentReference();
  ~AlignmentReference();
  AlignmentReference(AlignmentReference&&) noexcept;
  AlignmentReference& operator=(AlignmentReference&&) noexcept;

  /// Fits the planes of cloud[indices] (all finite points when indices is empty).
  void build(const Cloud& cloud, const AlignmentParams& params, const Indices& indices = {});
  bool empty() const;
  std::size_t planeCount() const;
  double cellSize() const;  ///< [m]
  double noise() const;     ///< median RMS thickness of the planes (point noise) [m]

 private:
  friend class FineAligner;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Estimates the correction of one sweep (see the file comment).
class FineAligner {
 public:
  /// Throws std::invalid_argument for invalid parameters.
  explicit FineAligner(const AlignmentParams& params);

  /// The correction for `current` (p_map = result.correction * p_given). Never throws on
  /// degenerate geometry: an empty sweep, no planes or too few matches give a rejected
  /// result with the reason in `status`.
  AlignmentResult estimate(const AlignmentReference& reference, const Cloud& current) const;

 private:
  AlignmentParams params_;
};

/// A copy of `cloud` moved by T: same order and size (NaN points stay NaN), sensor origin and
/// orientation moved too.
Cloud transformCloud(const Cloud& cloud, const Eigen::Isometry3d& T);

}  // namespace novelty_detection
