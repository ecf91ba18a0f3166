// The whole detection chain behind one class. ROS-free.
//
//   Pipeline pipeline(params);            // validates params (throws std::invalid_argument)
//   pipeline.setReference(map_cloud);     // pre-processing + model of the map, computed once
//   Result r = pipeline.detect(sweep);    // labels every input point, segments, superquadrics
#pragma once

#include <memory>

#include "novelty_detection/params.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

struct ReferenceModel;  // pre-processed reference points, its mixture, search structures

/// The costly part of a reference model that depends only on the reference cloud, its views
/// and the parameters (pre-processing, the multi-scale cut and EM): what a cache of the model
/// keeps between runs. The search structures and range images are rebuilt from the cloud.
struct ReferenceModelSummary {
  Indices kept;  ///< reference points surviving pre-processing, ascending (up frame = input's)
  Gmm gmm;       ///< Gamma
  /// Log-density under Gamma above which a point is explained by the map (+inf: off).
  double explained_log_density = 0.0;
};

class Pipeline {
 public:
  explicit Pipeline(const Params& params);
  ~Pipeline();
  Pipeline(Pipeline&&) noexcept;
  Pipeline& operator=(Pipeline&&) noexcept;

  const Params& params() const { return params_; }

  /// Builds and caches the reference model. Non-finite points are ignored. `views` (types.h)
  /// gives a map merged from several sweeps the origin of each, so that what any of them saw
  /// through counts as free; without it the cloud's own sensor_origin_ is its one viewpoint
  /// when known. Throws std::invalid_argument when fewer than a handful of finite points
  /// remain or when `views` does not match the cloud.
  void setReference(const Cloud& reference, const ReferenceViews& views = {});
  /// As above, with the summary a previous setReference of the same cloud, views and
  /// parameters gave (referenceSummary()): pre-processing and EM are skipped. Throws
  /// std::invalid_argument when the summary does not fit the cloud (an index out of range or
  /// on a non-finite point, indices not ascending, an invalid Gaussian).
  void setReference(const Cloud& reference, const ReferenceViews& views,
                    const ReferenceModelSummary& summary);
  /// The summary of the current reference model (empty without a reference).
  ReferenceModelSummary referenceSummary() const;
  /// How many sweep viewpoints the reference's visibility rules use (0: none known).
  std::size_t referenceViewpoints() const;
  bool hasReference() const { return reference_ != nullptr; }
  /// The reference cloud as given to setReference (for saving it).
  const Cloud& referenceCloud() const;
  /// The reference mixture Gamma (empty without a reference).
  const Gmm& referenceGmm() const;

  /// Compares `current` with the reference. Every input point gets a label (NaNs: 0).
  /// Throws std::logic_error without a reference, std::invalid_argument for a cloud
  /// larger than preprocess/max_points. An empty or all-NaN cloud yields no novelty.
  Result detect(const Cloud& current) const;

 private:
  Params params_;
  std::shared_ptr<const ReferenceModel> reference_;
};

}  // namespace novelty_detection
