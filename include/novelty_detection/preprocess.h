// Pre-processing (paper Sec. IV-A): drop non-finite points, sparse outlier removal
// (Rusu et al. 2008), RANSAC ground plane removal. Every step reports indices into the
// ORIGINAL input cloud, so each input point can be traced to the step that removed it.
#pragma once

#include "novelty_detection/params.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

/// A plane a*x + b*y + c*z + d = 0 with (a, b, c) unit length and c > 0 (normal up).
struct GroundPlane {
  bool found = false;
  Eigen::Vector4d coefficients = Eigen::Vector4d(0, 0, 1, 0);
  Indices inliers;  ///< input-cloud indices on the plane
};

struct PreprocessResult {
  Indices finite;    ///< input indices of finite points
  Indices outliers;  ///< input indices removed as sparse outliers
  GroundPlane ground;
  Indices kept;      ///< input indices surviving every step, ascending
};

/// Input indices of the points whose x, y, z are all finite.
Indices finiteIndices(const Cloud& cloud);

/// Statistical outlier removal over `indices`: a point is an outlier when the mean distance
/// to its k nearest neighbours exceeds mu + std_mul * sigma of those means. Returns the
/// kept indices (order preserved); the removed ones go to `removed` when given.
Indices removeSparseOutliers(const Cloud& cloud, const Indices& indices, int k, double std_mul,
                             Indices* removed = nullptr);

/// RANSAC plane within `max_angle_deg` of horizontal (normal near +z of the cloud's frame)
/// over `indices`; inliers within `distance_m`.
GroundPlane findGroundPlane(const Cloud& cloud, const Indices& indices, double distance_m,
                            double max_angle_deg, int max_iterations);

/// Chains the steps with one parameter struct.
class Preprocessor {
 public:
  explicit Preprocessor(const PreprocessParams& params);
  PreprocessResult compute(const Cloud& cloud) const;

 private:
  PreprocessParams params_;
};

}  // namespace novelty_detection
