// The detection chain (paper Fig. 2), one named stage after another (Pipeline::detect):
// fine alignment -> pre-processing and the multi-scale cut -> distances to the map (tau) ->
// the current mixture (EM) -> greedy EMD selection (Algorithm 1) -> novel points and their
// segments -> disappearances -> hidden-space rules -> labels -> newly visible points ->
// superquadrics (the stages: pipeline/detection.h). The reference's model is built once by
// setReference().
#include "novelty_detection/pipeline.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "novelty_detection/preprocess/ignore_regions.h"
#include "novelty_detection/preprocess/input_check.h"
#include "novelty_detection/visibility/visibility.h"
#include "pipeline/detection.h"
#include "reference_model.h"

namespace novelty_detection {

namespace {

using namespace stages;

/// The chain on a sweep already turned into the up frame.
Result detectInUpFrame(const Params& params_, const ReferenceModel& ref, const Cloud& input) {
  Detection d(params_, ref, input);
  alignToMap(input, d);
  simplifyAndMeasure(d);
  if (d.s.reps.size() == 0) return std::move(d.result);  // empty or all-NaN: nothing is novel
  if (markSelfReturns(d)) {
    d.result.point_counts.resize(1);  // "input": the counts follow the sweep without them
    // Outlier statistics of points whose neighbourhoods lost no robot return carry over.
    const PreprocessResult first = std::move(d.s.pre);
    simplifyAndMeasure(d, &first);
    if (d.s.reps.size() == 0) return std::move(d.result);
  }
  d.result.point_counts.emplace_back("self_returns", d.self_returns);
  fitCurrentMixture(d);
  selectNovelGaussians(d);
  segmentCandidates(d);
  addSparseGroups(d);
  d.s.pre.distinct_index.reset();  // the index over the kept points was their last user
  d.s.pre.statistics = {};
  buildCurrentView(d);
  findDisappearedStructure(d);
  addHiddenNovelties(d);
  addFreeContinuations(d);
  completeNewObjects(d);
  addTurnedContinuations(d);
  labelSegments(d);
  markNewlyVisible(d);
  fitSuperquadrics(d);
  return std::move(d.result);
}

}  // namespace

Pipeline::Pipeline(const Params& params) : params_(params) { params_.validate(); }
Pipeline::~Pipeline() = default;
Pipeline::Pipeline(Pipeline&&) noexcept = default;
Pipeline& Pipeline::operator=(Pipeline&&) noexcept = default;

Result Pipeline::detect(const Cloud& given) const {
  if (!reference_) throw std::logic_error("detect() called before setReference()");
  if (given.size() > static_cast<std::size_t>(params_.preprocess.max_points)) {
    throw std::invalid_argument("cloud has " + std::to_string(given.size()) +
                                " points, more than preprocess/max_points");
  }
  const ReferenceModel& ref = *reference_;
  // Absurd coordinates are missing points; a sweep off the map is refused.
  std::size_t out_of_range = 0;
  Cloud cleaned;
  const Cloud* view = &usableView(given, &cleaned, &out_of_range);
  // Ignore regions: their points are missing points too.
  const std::vector<IgnoreRegion> regions = parseIgnoreRegions(params_.preprocess.ignore_regions);
  std::size_t ignored = 0;
  if (!regions.empty()) {
    if (view != &cleaned) cleaned = given;
    ignored = maskIgnoreRegions(regions, cleaned);
    view = &cleaned;
  }
  const Cloud& input = *view;
  // Share of the sweep near the map: the floor of the distance is the one tau has.
  const double near_m = overlapDistance(ref.extent, params_.segmentation.min_novelty_distance_m);
  // The map's points are in the up frame, its extent in the input frame.
  const Eigen::Matrix3f R_up = ref.R_up.cast<float>();
  std::size_t usable = 0, near = 0;
  const std::size_t stride = std::max<std::size_t>(1, input.size() / 2000);
  for (std::size_t i = 0; i < input.size(); i += stride) {
    if (!usablePoint(input[i])) continue;
    ++usable;
    const Eigen::Vector3f p = point3f(input[i]);
    near += ref.points.within(ref.rotated ? Eigen::Vector3f(R_up * p) : p, near_m);
  }
  const double overlap = usable ? static_cast<double>(near) / usable : 1.0;
  requireOverlap(input, ref.extent, overlap);
  Result result = ref.rotated ? detectInUpFrame(params_, ref, rotateCloud(input, ref.R_up))
                              : detectInUpFrame(params_, ref, input);
  if (ref.rotated) toInputFrame(ref, input, &result);
  auto warn = [&](std::size_t n, const char* which) {
    if (n == 0) return;
    result.warnings.push_back(
        std::to_string(n) + " " + which + " points have a coordinate beyond " +
        std::to_string(static_cast<int>(kMaxCoordinateM)) + " m and were taken as missing");
  };
  warn(out_of_range, "sweep");
  warn(ref.out_of_range, "reference");
  result.up = ref.up.up;
  result.up_source = ref.up.source;
  result.overlap = overlap;
  result.ignored_points = ignored;
  result.ignored_disappearances = dropDisappearancesIn(regions, &result);
  result.visibility_checked = params_.segmentation.visibility_check && !ref.visibility.empty();
  result.disappearances_checked =
      params_.visibility.disappearances && sensorOriginKnown(input.sensor_origin_);
  return result;
}

void Pipeline::setReference(const Cloud& reference, const ReferenceViews& views) {
  reference_ = buildReferenceModel(params_, reference, views);
}

void Pipeline::setReference(const Cloud& reference, const ReferenceViews& views,
                            const ReferenceModelSummary& summary) {
  reference_ = buildReferenceModel(params_, reference, views, &summary);
}

ReferenceModelSummary Pipeline::referenceSummary() const {
  ReferenceModelSummary s;
  if (!reference_) return s;
  s.kept = reference_->kept;
  s.gmm = reference_->gmm;
  s.explained_log_density = reference_->explained_log_density;
  return s;
}

std::size_t Pipeline::referenceViewpoints() const {
  return reference_ ? reference_->visibility.views() : 0;
}

const Cloud& Pipeline::referenceCloud() const {
  if (!reference_) throw std::logic_error("no reference set");
  return reference_->rotated ? reference_->given : reference_->cloud;
}

const Gmm& Pipeline::referenceGmm() const {
  static const Gmm empty;
  return reference_ ? reference_->gmm : empty;
}

}  // namespace novelty_detection
