#include "novelty_detection/types.h"

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

}  // namespace novelty_detection
