// The reference's model and the first stages every cloud goes through (pre-processing and
// the multi-scale cut), shared by Pipeline::setReference and Pipeline::detect. Internal
// header: only the detector's sources include it.
#pragma once

#include <chrono>
#include <limits>
#include <memory>

#include "novelty_detection/alignment/alignment.h"
#include "novelty_detection/mixture/gmm.h"
#include "novelty_detection/params.h"
#include "novelty_detection/pipeline.h"
#include "novelty_detection/preprocess/multiscale_tree.h"
#include "novelty_detection/preprocess/preprocess.h"
#include "novelty_detection/preprocess/self_returns.h"
#include "novelty_detection/preprocess/up_direction.h"
#include "novelty_detection/segmentation/novelty_segmentation.h"
#include "novelty_detection/types.h"
#include "novelty_detection/visibility/visibility.h"

namespace novelty_detection {

struct ReferenceModel {
  ReferenceModel() = default;
  // Stays where it was made (shared): self_returns points at `cloud`.
  ReferenceModel(const ReferenceModel&) = delete;
  ReferenceModel& operator=(const ReferenceModel&) = delete;
  /// The up direction (preprocess/up) and the rotation R_up (up to +z) that both clouds are
  /// turned by about the origin before any stage; identity when up is +z.
  UpEstimate up;
  Eigen::Matrix3d R_up = Eigen::Matrix3d::Identity();
  bool rotated = false;
  Cloud given;                       ///< as given (kept only when rotated)
  Cloud cloud;                       ///< in the up frame (as given when not rotated)
  Eigen::AlignedBox3d extent;        ///< box of the usable points, input frame
  std::size_t out_of_range = 0;      ///< points beyond kMaxCoordinateM, taken as missing
  Gmm gmm;                           ///< Gamma
  NearestNeighbourIndex points;      ///< every finite reference point (ground included)
  NearestNeighbourIndex structure;   ///< the points of `kept`, in that order
  ReferenceVisibility visibility;    ///< free / occupied / unknown seen from its viewpoints
  ReferenceViews views;              ///< per-sweep origins (up frame) when given several
  Indices kept;                      ///< points that may disappear (no ground, no outliers)
  AlignmentReference planes;         ///< map planes for the fine alignment (when enabled)
  SelfReturnReference self_returns;  ///< the map's side of the robot-return test (of `cloud`)
  /// Log-density under Gamma that all but a `map_likelihood_quantile` share of the map's own
  /// points reach: a current point above it is explained by the map's surfaces.
  /// +inf when the check is off (no point counts as explained).
  double explained_log_density = std::numeric_limits<double>::infinity();
};

/// Appends the wall time since the previous lap to Result::timings under a stage's name.
class StageTimer {
 public:
  using Clock = std::chrono::steady_clock;
  explicit StageTimer(Result& r) : result_(r), start_(Clock::now()) {}
  void lap(const char* stage) {
    const auto now = Clock::now();
    result_.timings.push_back(
        {stage, std::chrono::duration<double, std::milli>(now - start_).count()});
    start_ = now;
  }

 private:
  Result& result_;
  Clock::time_point start_;
};

/// Pre-processing and the multi-scale cut of one cloud.
struct Simplified {
  PreprocessResult pre;
  MultiScaleTree tree;
  MultiScaleTree::Cut fine;  ///< the (n_max, sigma_max) cut: where new surfaces are sought
  MultiScaleTree::Cut cut;   ///< the scale EM is fitted at (fine, or coarser when too many)
  WeightedPoints reps;       ///< `cut` as weighted points
};

/// `cloud` turned by R about the origin, its sensor origin too (its known flag kept).
Cloud rotateCloud(const Cloud& cloud, const Eigen::Matrix3d& R);

/// A result computed in the up frame, expressed in the input frame again (R_up^T): segments'
/// boxes are recomputed from `input` (boxes do not rotate), the rest rotates.
void toInputFrame(const ReferenceModel& ref, const Cloud& input, Result* r);

/// Pre-processing and the multi-scale cut of `cloud`; with `result`, its point counts and
/// (with `timer`) the stage times are recorded.
/// `earlier`: pre-processing of the same cloud before some of its points became non-finite
/// (Preprocessor::setEarlier).
Simplified simplify(const Params& params, const Cloud& cloud, Result* result, StageTimer* timer,
                    const PreprocessResult* earlier = nullptr);

/// Everything detect() needs of the reference, computed once. `views` (may be empty) says
/// which sweep each point came from and where it was seen from (types.h). Throws
/// std::invalid_argument when fewer than 4 usable points remain after pre-processing, or
/// when `views` does not match the cloud.
/// With `summary` (Pipeline::setReference), pre-processing and EM are taken from it.
std::shared_ptr<const ReferenceModel> buildReferenceModel(
    const Params& params, const Cloud& reference, const ReferenceViews& views = {},
    const ReferenceModelSummary* summary = nullptr);
/// The rest of buildReferenceModel, once model->cloud is in the up frame.
std::shared_ptr<const ReferenceModel> buildReferenceModelInUpFrame(
    const Params& params, std::shared_ptr<ReferenceModel> model,
    const ReferenceModelSummary* summary = nullptr);

}  // namespace novelty_detection
