// Pre-processing (paper Sec. IV-A): drop non-finite points, sparse outlier removal
// (Rusu et al. 2008), RANSAC ground plane removal. Every step reports indices into the
// ORIGINAL input cloud, so each input point can be traced to the step that removed it.
#pragma once

#include <memory>

#include "novelty_detection/params.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

class NearestNeighbourIndex;

/// A plane a*x + b*y + c*z + d = 0 with (a, b, c) unit length and c > 0 (normal up).
struct GroundPlane {
  bool found = false;
  Eigen::Vector4d coefficients = Eigen::Vector4d(0, 0, 1, 0);
  Indices inliers;             ///< input-cloud indices on the plane
  double noise_sigma_m = 0.0;  ///< robust (MAD) scale of the floor's residuals
  double threshold_m = 0.0;    ///< inlier distance used: max(distance, k * noise_sigma_m)
};

struct PreprocessResult {
  Indices finite;  ///< input indices of finite points
  /// Finite points equal to an earlier point (x, y, z bit for bit), left out of every later
  /// step: repeated returns carry no information but would double a surface's density.
  /// duplicate_of[k] is the first occurrence of duplicates[k]; both ascending in duplicates.
  Indices duplicates, duplicate_of;
  Indices outliers;  ///< input indices removed as sparse outliers
  GroundPlane ground;
  Indices kept;  ///< input indices surviving every step, ascending
  /// The index outlier removal searched: every distinct finite point (`finite` without
  /// `duplicates`, in that order). Later stages that query the whole sweep use it instead of
  /// indexing the sweep again. Null when outlier removal is off or had no statistics to make.
  std::shared_ptr<const NearestNeighbourIndex> distinct_index;
  /// The statistics outlier removal made, per point of distinct_index (same order): input
  /// index, mean distance to its outlier_k nearest other points and the k-th of those
  /// distances. A later run on the same sweep with some of these points gone reuses them
  /// (Preprocessor::setEarlier). Empty when outlier removal did not run.
  struct NeighbourStatistics {
    int k = 0;
    Indices points;
    std::vector<double> mean, kth;
    std::size_t reused = 0;  ///< points whose values came from the earlier run
  } statistics;
};

/// Input indices of the points whose x, y, z are all finite.
Indices finiteIndices(const Cloud& cloud);

/// Splits `indices` (ascending) into the first occurrence of each distinct point (returned,
/// ascending) and the repeats (`duplicates`, with their first occurrence in `duplicate_of`).
Indices removeDuplicates(const Cloud& cloud, const Indices& indices, Indices* duplicates,
                         Indices* duplicate_of);

/// Statistical outlier removal over `indices`: a point is an outlier when the mean distance
/// to its k nearest neighbours exceeds mu + std_mul * sigma of those means. Returns the
/// kept indices (order preserved); the removed ones go to `removed` when given. The
/// neighbour search runs on up to `threads` threads; the result does not depend on it.
Indices removeSparseOutliers(const Cloud& cloud, const Indices& indices, int k, double std_mul,
                             Indices* removed = nullptr, int threads = 1);

/// As above, but a point is removed only when it is an outlier both by that statistic and by
/// the same statistic over the mean distances divided by each point's range from
/// `sensor_origin` (at least 1 m): a scanning sensor samples at fixed angles, so its spacing
/// grows with range, and the global statistic alone would take far, sparsely sampled walls
/// and objects (a person 5 m away) for outliers; the range-divided one alone would drop near
/// points that are sparse only next to far ones.
Indices removeSparseOutliersRangeScaled(const Cloud& cloud, const Indices& indices, int k,
                                        double std_mul, const Eigen::Vector3f& sensor_origin,
                                        Indices* removed = nullptr, int threads = 1);

/// RANSAC plane within `max_angle_deg` of horizontal (normal near +z of the cloud's frame)
/// over `indices`; inliers within `distance_m`. The other settings take PreprocessParams'
/// defaults (see the overload below, which this calls).
GroundPlane findGroundPlane(const Cloud& cloud, const Indices& indices, double distance_m,
                            double max_angle_deg, int max_iterations);

/// Ground plane with every ground_* setting of `params`:
///  1. RANSAC: random triples give plane hypotheses; those tilted more than
///     ground_max_angle_deg from +z are skipped; each is scored by its inliers within
///     ground_distance_m on a random subset of ground_sample_points points. Among the
///     hypotheses with at least ground_lowest_support of the best score the LOWEST wins, so
///     a ceiling or a table top seen more densely than the floor is not taken for it.
///  2. Refinement (on the same subset): the normal by least squares and the offset by the
///     median residual of the points within 3 sigma, sigma = 1.4826 * MAD of those residuals,
///     iterated to a fixed point (sigma starts at ground_distance_m). The median is robust to what
///     stands on the floor (boxes, the foot of walls), which only ever lies above it.
///  3. Inliers: |distance| <= max(ground_distance_m, ground_noise_k * sigma).
///     A quarter of the hypotheses are drawn from the lowest fifth of the subset (by z),
///     so the floor is among them even when it holds a small share of the sweep.
///     With `sensor_origin`, a plane is a hypothesis only when the sensor lies above it by
///     more than ground_distance_m: a tilting or 2D laser puts each scan line in a plane
///     through the sensor, and near-horizontal lines (walls all around at sensor height)
///     can hold more points than the floor.
/// found = false when fewer than 3 points, no hypothesis within the angle, or fewer than
/// ground_min_fraction of the points on the plane. Deterministic (fixed seed); the planes are
/// scored and refined on up to `threads` threads, with the same result.
GroundPlane findGroundPlane(const Cloud& cloud, const Indices& indices,
                            const PreprocessParams& params,
                            const Eigen::Vector3f* sensor_origin = nullptr, int threads = 1);

/// Chains the steps with one parameter struct: finite -> sparse outliers -> ground.
class Preprocessor {
 public:
  /// Throws std::invalid_argument when params.validate() does.
  explicit Preprocessor(const PreprocessParams& params);
  /// Throws std::invalid_argument for a cloud larger than max_points. An empty or
  /// all-NaN cloud gives an empty result; a cloud too small for a step (fewer than 2
  /// points for outliers, 3 for a plane) passes that step unchanged.
  PreprocessResult compute(const Cloud& cloud) const;
  /// With the sensor position given explicitly (compute(cloud) uses cloud.sensor_origin_,
  /// PCL's viewpoint, which the simulator and saveCloudAtomic fill in).
  PreprocessResult compute(const Cloud& cloud, const Eigen::Vector3f& sensor_origin) const;
  /// With the origin and whether it is known stated explicitly.
  PreprocessResult compute(const Cloud& cloud, const Eigen::Vector3f& sensor_origin,
                           bool origin_known) const;
  /// Threads for the neighbour statistics (compute/threads resolved; default 1). Results
  /// do not depend on it.
  Preprocessor& setThreads(int threads) {
    threads_ = threads;
    return *this;
  }
  /// An earlier result on the same cloud of which some points have since become non-finite
  /// (the robot's own returns, once found): the neighbour statistics of the points whose k
  /// nearest neighbours were all kept (none of the lost points lies within their k-th
  /// distance) are taken from it instead of searched again. The result is the same.
  /// `earlier` must outlive compute().
  Preprocessor& setEarlier(const PreprocessResult* earlier) {
    earlier_ = earlier;
    return *this;
  }

 private:
  PreprocessParams params_;
  int threads_ = 1;
  const PreprocessResult* earlier_ = nullptr;
};

}  // namespace novelty_detection
