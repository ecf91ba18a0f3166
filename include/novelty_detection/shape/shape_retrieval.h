// Shape retrieval (paper Sec. V): superquadrics for one novelty segment. ROS-free.
#pragma once

#include <vector>

#include "novelty_detection/params.h"
#include "novelty_detection/shape/fit_bounds.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

class ShapeRetrieval {
 public:
  explicit ShapeRetrieval(const SuperquadricParams& params);

  /// Superquadrics describing one segment. `fine`: all its points; `coarse`: a subset of
  /// them (the multi-scale cut's representatives inside the segment), used for the first
  /// fit before refining on `fine` (Sec. V-B). Returned parts carry `indices` into `fine`,
  /// `points` and `residual`; `segment` is set to segment_id. `bounds` (optional,
  /// fit_bounds.h): what the sweep observed around the segment; the final fits (the whole
  /// segment's, or each part's) are refined within them.
  std::vector<Superquadric> recover(const Points3d& fine, const Points3d& coarse, int segment_id,
                                    const FitBounds* bounds = nullptr) const;

  /// Threads for independent fits (compute/threads); results do not depend on it.
  /// Default: ComputeParams().resolved().
  void setThreads(int threads) { threads_ = threads < 1 ? 1 : threads; }

 private:
  SuperquadricParams params_;
  int threads_ = ComputeParams().resolved();
};

}  // namespace novelty_detection
