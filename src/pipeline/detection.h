// The state one Pipeline::detect() call hands from stage to stage, and the stages that
// read and extend it, in the order detectInUpFrame() (src/pipeline.cpp) runs them. Each stage
// is documented where it is defined: the sweep's own stages (alignment, pre-processing and the
// multi-scale cut, robot returns, tau, the mixture, the selection, the novel points and the
// sparse groups) in sweep_stages.cpp, the rest (views, disappearances, hidden space, object
// completion, surfaces that turned, labels, newly visible points, superquadrics) in
// object_stages.cpp. Internal header: only the detector's sources include it.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

#include "novelty_detection/mixture/gmm.h"
#include "novelty_detection/mixture/novelty_selection.h"
#include "novelty_detection/params.h"
#include "novelty_detection/preprocess/range_noise.h"
#include "novelty_detection/segmentation/novelty_segmentation.h"
#include "novelty_detection/types.h"
#include "novelty_detection/visibility/visibility.h"
#include "reference_model.h"
#include "segmentation/novelty_candidates.h"

namespace novelty_detection {
namespace stages {

inline Eigen::Vector3f point3f(const PointT& p) { return Eigen::Vector3f(p.x, p.y, p.z); }

/// Orders segments' pieces largest first (ties keep their order): segments are numbered so.
inline void sortLargestFirst(std::vector<Indices>* pieces) {
  std::stable_sort(pieces->begin(), pieces->end(),
                   [](const Indices& a, const Indices& b) { return a.size() > b.size(); });
}

/// The state one detect() call hands from stage to stage.
struct Detection {
  Detection(const Params& p, const ReferenceModel& r, const Cloud& input)
      : params(p), ref(r), timer(result) {
    result.labels.assign(input.size(), 0);
    result.newly_visible.assign(input.size(), 0);
    result.disappeared_labels.assign(ref.cloud.size(), 0);
    result.point_counts.emplace_back("input", input.size());
  }
  const Params& params;
  const ReferenceModel& ref;
  Result result;
  StageTimer timer;
  Cloud aligned;                     ///< the sweep moved by the fine alignment, when applied
  const Cloud* current = nullptr;    ///< the sweep in the map frame (input or aligned)
  Cloud without_self;                ///< the sweep with its self-returns set to NaN, when any
  std::size_t self_returns = 0;      ///< current points taken for the robot
  Indices disappearance_candidates;  ///< ref.kept without the reference's self-returns
  Simplified s;
  double tau = 0.0;    ///< novelty distance from the data (novelty_segmentation.h)
  WeightedPoints far;  ///< fine clusters farther than tau from the map
  SelectionResult selection;
  detail::NoveltyCandidates candidates;
  std::vector<Indices> pieces;  ///< the segments' points, largest first
  std::vector<int> owner_of;    ///< per current point: its novel Gaussian, or -1
  double link_radius = 0.0;
  NearestNeighbourIndex kept_index;  ///< over s.pre.kept, in that order
  RangeNoise noise;                  ///< the sweep's range noise model (preprocess/range_noise.h)
  RangeImage current_view;           ///< the sweep from its own origin (when needed and known)
};

// sweep_stages.cpp
void alignToMap(const Cloud& input, Detection& d);
/// `earlier`: the pre-processing of the sweep before its robot returns became NaN.
void simplifyAndMeasure(Detection& d, const PreprocessResult* earlier = nullptr);
bool markSelfReturns(Detection& d);
void fitCurrentMixture(Detection& d);
void selectNovelGaussians(Detection& d);
void segmentCandidates(Detection& d);
void addSparseGroups(Detection& d);

// object_stages.cpp
void buildCurrentView(Detection& d);
void findDisappearedStructure(Detection& d);
void addHiddenNovelties(Detection& d);
void addFreeContinuations(Detection& d);
void completeNewObjects(Detection& d);
void addTurnedContinuations(Detection& d);
void labelSegments(Detection& d);
void markNewlyVisible(Detection& d);
void fitSuperquadrics(Detection& d);

}  // namespace stages
}  // namespace novelty_detection
