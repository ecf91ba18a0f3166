#include "novelty_detection/segmentation/surface_creases.h"

#include <cmath>
#include <utility>

#include "plane_fit.h"

namespace novelty_detection {

CreaseTest::CreaseTest(const Cloud& cloud, const Indices& kept, const NearestNeighbourIndex& index,
                       const Eigen::Vector3f& origin, double radius_m, double offset_factor,
                       std::function<double(double)> sigma_at, double near_radius_m)
    : cloud_(cloud),
      kept_(kept),
      index_(index),
      origin_(origin),
      radius_(radius_m),
      factor_(offset_factor),
      near_radius_(near_radius_m),
      sigma_at_(std::move(sigma_at)),
      state_(kept.size(), -1),
      near_(kept.size(), -1) {}

bool CreaseTest::inCrease(int position) {
  signed char& state = state_.at(static_cast<std::size_t>(position));
  if (state >= 0) return state == 1;
  state = 0;
  if (!(radius_ > 0) || !(factor_ > 0) || index_.size() != kept_.size()) return false;
  const Eigen::Vector3f p = cloud_[kept_[position]].getVector3fMap();
  const NearestNeighbourIndex::Neighbourhood around = index_.neighbourhood(p, radius_);
  if (static_cast<int>(around.count) < kMinCreaseNeighbours) return false;
  const detail::Plane plane = detail::planeOf(around.centroid, around.covariance);
  // Neighbours along a line (one scan line): the "plane" is undetermined.
  if (!(plane.sd(1) * plane.sd(1) > 0.05 * plane.sd(2) * plane.sd(2))) return false;
  Eigen::Vector3d n = plane.normal;
  const Eigen::Vector3d to_sensor = (origin_ - p).cast<double>();
  const double range = to_sensor.norm();
  if (!(range > 0)) return false;
  double facing = n.dot(to_sensor) / range;
  if (facing < 0) n = -n, facing = -facing;
  if (facing < 0.2) return false;  // seen edge-on
  const double offset = (plane.centroid - p.cast<double>()).dot(n);
  const double sigma = sigma_at_ ? sigma_at_(range) : 0.0;
  if (sigma > 0 && offset > factor_ * sigma) state = 1;
  return state == 1;
}

bool CreaseTest::nearCrease(int position) {
  signed char& known = near_.at(static_cast<std::size_t>(position));
  if (known >= 0) return known == 1;
  known = inCrease(position) ? 1 : 0;
  if (known || !(near_radius_ > 0) || index_.size() != kept_.size()) return known == 1;
  near_nn_.clear();
  index_.withinIds(cloud_[kept_[position]].getVector3fMap(), near_radius_, &near_nn_);
  for (int id : near_nn_)
    if (inCrease(id)) return (near_[static_cast<std::size_t>(position)] = 1) == 1;
  return false;
}

}  // namespace novelty_detection
