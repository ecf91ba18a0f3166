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
