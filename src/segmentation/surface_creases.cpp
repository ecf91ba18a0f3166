#include "novelty_detection/segmentation/surface_creases.h"

#include <cmath>
#include <utility>

#include "common/parallel.h"
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
  if (state < 0) state = test(position) ? 1 : 0;
  return state == 1;
}

bool CreaseTest::test(int position) const {
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
  return sigma > 0 && offset > factor_ * sigma;
}

bool CreaseTest::nearCrease(int position) {
  const signed char known = near_.at(static_cast<std::size_t>(position));
  if (known >= 0) return known == 1;
  near_nn_.clear();
  if (!inCrease(position) && near_radius_ > 0 && index_.size() == kept_.size())
    index_.withinIds(cloud_[kept_[position]].getVector3fMap(), near_radius_, &near_nn_);
  return settle(position, near_nn_);
}

bool CreaseTest::settle(int position, const std::vector<int>& near) {
  bool yes = inCrease(position);
  for (std::size_t k = 0; !yes && k < near.size(); ++k) yes = inCrease(near[k]);
  near_[static_cast<std::size_t>(position)] = yes ? 1 : 0;
  return yes;
}

void CreaseTest::prepare(const std::vector<int>& positions, int threads) {
  if (threads <= 1 || positions.empty() || index_.size() != kept_.size()) return;
  const int n = static_cast<int>(positions.size());
  // Each position's neighbours within near_radius_ (nearCrease's list), then the test of
  // every point either of them needs, once, then the answers; each step writes only its own
  // slots.
  std::vector<std::vector<int>> near(static_cast<std::size_t>(n));
  constexpr int kBlock = 256;
  if (near_radius_ > 0) {
    detail::parallelForBlocks(n, kBlock, threads, [&](int k) {
      const int p = positions[static_cast<std::size_t>(k)];
      index_.withinIds(cloud_[kept_[p]].getVector3fMap(), near_radius_,
                       &near[static_cast<std::size_t>(k)]);
    });
  }
  std::vector<char> wanted(kept_.size(), 0);
  std::vector<int> todo;
  auto want = [&](int p) {
    if (state_[static_cast<std::size_t>(p)] < 0 && !wanted[static_cast<std::size_t>(p)])
      wanted[static_cast<std::size_t>(p)] = 1, todo.push_back(p);
  };
  for (int k = 0; k < n; ++k) {
    want(positions[static_cast<std::size_t>(k)]);
    for (int q : near[static_cast<std::size_t>(k)]) want(q);
  }
  detail::parallelForBlocks(static_cast<int>(todo.size()), kBlock, threads, [&](int k) {
    const int p = todo[static_cast<std::size_t>(k)];
    state_[static_cast<std::size_t>(p)] = test(p) ? 1 : 0;
  });
  // Every test asked below is answered above: this only reads them.
  for (int k = 0; k < n; ++k) {
    const int p = positions[static_cast<std::size_t>(k)];
    if (near_[static_cast<std::size_t>(p)] < 0) settle(p, near[static_cast<std::size_t>(k)]);
  }
}

void CreaseTest::prepareSegments(const std::vector<Indices>& segments, int threads) {
  if (threads <= 1) return;
  std::vector<int> position(cloud_.size(), -1);
  for (std::size_t k = 0; k < kept_.size(); ++k)
    position[static_cast<std::size_t>(kept_[k])] = static_cast<int>(k);
  std::vector<int> positions;
  for (const Indices& segment : segments)
    for (int i : segment)
      if (i >= 0 && static_cast<std::size_t>(i) < position.size() &&
          position[static_cast<std::size_t>(i)] >= 0)
        positions.push_back(position[static_cast<std::size_t>(i)]);
  prepare(positions, threads);
}

}  // namespace novelty_detection
