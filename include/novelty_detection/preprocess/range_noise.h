// The sensor's noise model, estimated from the sweep itself: how the thickness of its
// surfaces grows with range. A laser's range noise is roughly constant or grows linearly with
// range; a depth camera's grows with depth squared. ROS-free.
//
// Votes: the plate-like nodes of the multi-scale tree (16..256 points, in-plane spread well
// above the thickness), each an unbiased estimate of the noise variance normal to its surface
// (MultiScaleTree::noiseVote), at the range of its centroid from the sensor. Model:
// sigma(r) = c * r^p with p in {0, 1, 2}; for each p, log c is the median of
// log sigma_i - p log r_i and the model's score the median absolute residual; the lowest
// score wins, and p = 0 is kept unless the votes span a range ratio of at least
// kMinRangeRatio (a short span cannot tell the models apart). Without a known sensor origin
// only p = 0 is fitted. The medians ignore the minority of votes on edges and corners. Only
// surfaces whose thickness is well below their extent vote, so where the noise is as large
// as the patches (far, grazing) the model extrapolates from the nearer surfaces.
#pragma once

#include <Eigen/Core>

#include <string>

#include "novelty_detection/preprocess/multiscale_tree.h"

namespace novelty_detection {

struct RangeNoise {
  bool estimated = false;  ///< false: too few votes (every sigma is then 0)
  double exponent = 0.0;   ///< p of sigma = scale * r^p
  double scale = 0.0;      ///< c [m / m^p]
  int votes = 0;           ///< plate-like nodes that voted

  /// The noise standard deviation normal to a surface at range r [m].
  double sigmaAt(double range_m) const;
  /// "constant", "linear in range" or "quadratic in range".
  std::string modelName() const;
};

/// Votes needed for an estimate.
constexpr int kMinNoiseVotes = 20;
/// The range ratio (90th over 10th percentile of the votes) needed to fit p > 0.
constexpr double kMinRangeRatio = 1.5;

/// Fits the model to the tree's votes; `origin` is the sensor (nullptr when unknown).
RangeNoise estimateRangeNoise(const MultiScaleTree& tree, const Eigen::Vector3f* origin);

}  // namespace novelty_detection
