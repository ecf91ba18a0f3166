// The best plane through a set of points (principal components), shared by the segmentation
// rules. Internal to the segmentation stage.
#pragma once

#include <Eigen/Core>
#include <Eigen/Eigenvalues>

#include "novelty_detection/types.h"

namespace novelty_detection {
namespace detail {

struct Plane {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< smallest principal direction
  Eigen::Vector3d sd = Eigen::Vector3d::Zero();       ///< principal standard deviations, ascending
};

/// The plane through `centroid` of points with covariance `cov`.
inline Plane planeOf(const Eigen::Vector3d& centroid, const Eigen::Matrix3d& cov) {
  Plane p;
  p.centroid = centroid;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  p.normal = es.eigenvectors().col(0);
  p.sd = es.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  return p;
}

/// The plane of cloud[indices] (not empty).
inline Plane fitPlane(const Cloud& cloud, const Indices& indices) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (int i : indices) centroid += cloud[i].getVector3fMap().cast<double>();
  centroid /= static_cast<double>(indices.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (int i : indices) {
    const Eigen::Vector3d d = cloud[i].getVector3fMap().cast<double>() - centroid;
    cov += d * d.transpose();
  }
  return planeOf(centroid, cov / static_cast<double>(indices.size()));
}

}  // namespace detail
}  // namespace novelty_detection
