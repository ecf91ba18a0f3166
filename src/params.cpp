#include "novelty_detection/params.h"

#include "novelty_detection/preprocess/ignore_regions.h"
#include "novelty_detection/preprocess/self_returns.h"
#include "novelty_detection/preprocess/sensor_origin.h"
#include "novelty_detection/preprocess/up_direction.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <thread>
#include <type_traits>

namespace novelty_detection {
namespace {

/// Throws when a numeric field lies outside the range its visit() entry states. Bounds are
/// printed in the field's own type (ints as ints).
template <class Group>
void validateRanges(const char* group, const Group& params) {
  // visit() hands out mutable references; this visitor only reads them.
  const_cast<Group&>(params).visit(
      [group](const char* name, const auto& value, const ParamInfo& info) {
        using T = std::decay_t<decltype(value)>;
        if constexpr (std::is_arithmetic_v<T> && !std::is_same_v<T, bool>) {
          const double v = static_cast<double>(value);
          if (v >= info.min && v <= info.max) return;
          std::ostringstream msg;
          msg << "parameter " << group << "/" << name << " = " << value << " is out of range [";
          if (std::isfinite(info.min))
            msg << static_cast<T>(info.min);
          else
            msg << "-inf";
          msg << ", ";
          if (std::isfinite(info.max))
            msg << static_cast<T>(info.max);
          else
            msg << "inf";
          msg << "]";
          throw std::invalid_argument(msg.str());
        }
      });
}

}  // namespace

void PreprocessParams::validate() const {
  parseUp(up);  // throws naming preprocess/up
  parseOrigin("preprocess/reference_origin", reference_origin);
  parseOrigin("preprocess/current_origin", current_origin);
  parseBodyBox(body_box);
  parseIgnoreRegions(ignore_regions);
  validateRanges("preprocess", *this);
}

void MultiScaleParams::validate() const { validateRanges("multiscale", *this); }

void GmmParams::validate() const { validateRanges("gmm", *this); }

void SelectionParams::validate() const {
  if (ground_distance != "wasserstein" && ground_distance != "euclidean") {
    throw std::invalid_argument("parameter selection/ground_distance = '" + ground_distance +
                                "' must be 'wasserstein' or 'euclidean'");
  }
  validateRanges("selection", *this);
}

void SegmentationParams::validate() const { validateRanges("segmentation", *this); }

void VisibilityParams::validate() const { validateRanges("visibility", *this); }

void SuperquadricParams::validate() const {
  validateRanges("superquadric", *this);
  if (epsilon_min >= epsilon_max) {
    throw std::invalid_argument("parameter superquadric/epsilon_min must be below epsilon_max");
  }
  if (robust_loss != "none" && robust_loss != "huber" && robust_loss != "cauchy") {
    throw std::invalid_argument("parameter superquadric/robust_loss = '" + robust_loss +
                                "' must be 'none', 'huber' or 'cauchy'");
  }
}

void AlignmentParams::validate() const { validateRanges("alignment", *this); }

void ComputeParams::validate() const { validateRanges("compute", *this); }

void TrackingParams::validate() const { validateRanges("tracking", *this); }

int ComputeParams::resolved() const {
  if (threads > 0) return threads;
  const unsigned hw = std::thread::hardware_concurrency();
  return static_cast<int>(std::min(8u, std::max(1u, hw)));
}

void Params::validate() const {
  preprocess.validate();
  multiscale.validate();
  gmm.validate();
  selection.validate();
  segmentation.validate();
  visibility.validate();
  superquadric.validate();
  alignment.validate();
  compute.validate();
  tracking.validate();
}

}  // namespace novelty_detection
