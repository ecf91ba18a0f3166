#include "novelty_detection/types.h"

#include "novelty_detection/preprocess/input_check.h"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace novelty_detection {

void checkReferenceViews(const Cloud& cloud, const ReferenceViews& views) {
  if (views.empty()) {
    if (!views.sweep.empty())
      throw std::invalid_argument("reference views: sweep indices without sweep origins");
    return;
  }
  if (views.sweep.size() != cloud.size()) {
    throw std::invalid_argument("reference views: " + std::to_string(views.sweep.size()) +
                                " sweep indices for " + std::to_string(cloud.size()) + " points");
  }
  for (const Eigen::Vector3f& o : views.origins)
    if (!o.allFinite() || !usablePoint(PointT(o.x(), o.y(), o.z())))
      throw std::invalid_argument("reference views: a sweep origin is not finite");
  for (std::uint32_t k : views.sweep)
    if (k >= views.origins.size())
      throw std::invalid_argument("reference views: a point names sweep " + std::to_string(k) +
                                  " of " + std::to_string(views.origins.size()));
}

Eigen::Matrix3d Superquadric::rotation() const {
  // Z-Y-Z Euler angles (phi, theta, psi).
  return (Eigen::AngleAxisd(euler[0], Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(euler[1], Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(euler[2], Eigen::Vector3d::UnitZ()))
      .toRotationMatrix();
}

Eigen::Quaterniond Superquadric::quaternion() const {
  return Eigen::Quaterniond(rotation()).normalized();
}

std::vector<StageTiming> stageTotals(const std::vector<StageTiming>& timings) {
  std::vector<StageTiming> out;
  for (const StageTiming& t : timings) {
    auto it = std::find_if(out.begin(), out.end(),
                           [&t](const StageTiming& o) { return o.stage == t.stage; });
    if (it == out.end()) {
      out.push_back(t);
    } else {
      it->ms += t.ms;
    }
  }
  return out;
}

const char* floorSupportName(FloorSupport support) {
  switch (support) {
    case FloorSupport::kPoints:
      return "points";
    case FloorSupport::kFloorAtFoot:
      return "floor_at_foot";
    case FloorSupport::kHidden:
      return "hidden";
    case FloorSupport::kNone:
      break;
  }
  return "none";
}

Segment makeSegment(const Cloud& cloud, Indices indices, int id) {
  Segment s;
  s.id = id;
  s.indices = std::move(indices);
  s.bbox_min.setConstant(std::numeric_limits<double>::infinity());
  s.bbox_max.setConstant(-std::numeric_limits<double>::infinity());
  for (int i : s.indices) {
    const Eigen::Vector3d p = cloud[i].getVector3fMap().cast<double>();
    s.centroid += p;
    s.bbox_min = s.bbox_min.cwiseMin(p);
    s.bbox_max = s.bbox_max.cwiseMax(p);
  }
  if (!s.indices.empty()) s.centroid /= static_cast<double>(s.indices.size());
  return s;
}

}  // namespace novelty_detection
