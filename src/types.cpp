#include "novelty_detection/types.h"

#include <limits>
#include <utility>

namespace novelty_detection {

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
