// ChoosePtfromGaussian (paper Sec. IV-D) with the visibility rule of visibility.h: which
// kept points of the current sweep are novel, and which far candidates the reference could
// not see (newly visible: the hidden-segment rules look at those). Internal header: only
// core sources include it.
#pragma once

#include <vector>

#include "novelty_detection/mixture/gmm.h"
#include "novelty_detection/params.h"
#include "novelty_detection/segmentation/novelty_segmentation.h"
#include "novelty_detection/types.h"
#include "novelty_detection/visibility/visibility.h"

namespace novelty_detection {
namespace detail {

struct NoveltyCandidates {
  Indices novel;                       ///< ascending input indices of the novel points
  std::vector<int> owner;              ///< per novel point: its most probable novel Gaussian
  Indices hidden;                      ///< ascending: far candidates the point rule calls hidden
  std::vector<int> hidden_owner;       ///< per hidden point: its most probable novel Gaussian
  std::vector<Visibility> hidden_vis;  ///< per hidden point: reference visibility
};

/// What the reference contributes.
struct CandidateReference {
  const Gmm* gmm = nullptr;                         ///< Gamma
  const NearestNeighbourIndex* points = nullptr;    ///< every finite reference point
  const ReferenceVisibility* visibility = nullptr;  ///< empty without a reference viewpoint
  double explained_log_density = 0.0;               ///< see Pipeline's ReferenceModel
};

/// Among `kept` (ascending indices into `current`), the points whose posterior mass on the
/// `novel` Gaussians of `theta` exceeds posterior_threshold and that lie farther than tau
/// from every reference point, split by the fused rule novelCandidate. `reps` are the
/// representatives of the cut EM was fitted at and `cluster_of` maps an input index to its
/// representative (-1 if none): only points of clusters with some novel posterior mass
/// are evaluated one by one.
NoveltyCandidates chooseNoveltyCandidates(const Cloud& current, const Indices& kept,
                                          const std::vector<int>& cluster_of,
                                          const WeightedPoints& reps, const Gmm& theta,
                                          const std::vector<int>& novel,
                                          const CandidateReference& reference, double tau,
                                          const Params& params);

}  // namespace detail
}  // namespace novelty_detection
