#include "novelty_detection/pipeline.h"

#include <cmath>
#include <stdexcept>

namespace novelty_detection {

struct ReferenceModel {
  Cloud cloud;
  Gmm gmm;
};

Pipeline::Pipeline(const Params& params) : params_(params) { params_.validate(); }
Pipeline::~Pipeline() = default;
Pipeline::Pipeline(Pipeline&&) noexcept = default;
Pipeline& Pipeline::operator=(Pipeline&&) noexcept = default;

void Pipeline::setReference(const Cloud& reference) {
  auto model = std::make_shared<ReferenceModel>();
  model->cloud = reference;
  reference_ = model;
}

const Cloud& Pipeline::referenceCloud() const {
  if (!reference_) throw std::logic_error("no reference set");
  return reference_->cloud;
}

const Gmm& Pipeline::referenceGmm() const {
  static const Gmm empty;
  return reference_ ? reference_->gmm : empty;
}

Result Pipeline::detect(const Cloud& current) const {
  if (!reference_) throw std::logic_error("detect() called before setReference()");
  if (current.size() > static_cast<std::size_t>(params_.preprocess.max_points)) {
    throw std::invalid_argument("cloud has " + std::to_string(current.size()) +
                                " points, more than preprocess/max_points");
  }
  Result result;
  result.labels.assign(current.size(), 0);
  result.point_counts.emplace_back("input", current.size());
  return result;
}

}  // namespace novelty_detection
