#include "novelty_detection/segmentation/novelty_segmentation.h"

#include "common/knn.h"

#include <cmath>
#include <memory>
#include <vector>

namespace novelty_detection {

struct NearestNeighbourIndex::Impl {
  std::vector<Eigen::Vector3f> points;  ///< the indexed points, in build order
  detail::KnnTree tree;
};

NearestNeighbourIndex::NearestNeighbourIndex() : impl_(std::make_unique<Impl>()) {}
NearestNeighbourIndex::~NearestNeighbourIndex() = default;
NearestNeighbourIndex::NearestNeighbourIndex(NearestNeighbourIndex&&) noexcept = default;
NearestNeighbourIndex& NearestNeighbourIndex::operator=(NearestNeighbourIndex&&) noexcept = default;

void NearestNeighbourIndex::build(const Cloud& cloud, const Indices& indices, int threads) {
  impl_ = std::make_unique<Impl>();
  auto add = [&](const PointT& p) {
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))
      impl_->points.emplace_back(p.x, p.y, p.z);
  };
  if (indices.empty()) {
    impl_->points.reserve(cloud.size());
    for (const auto& p : cloud) add(p);
  } else {
    impl_->points.reserve(indices.size());
    for (int i : indices) add(cloud[i]);
  }
  impl_->tree = detail::KnnTree(impl_->points, threads);
}

NearestNeighbourIndex NearestNeighbourIndex::restricted(const std::vector<char>& keep) const {
  NearestNeighbourIndex out;
  out.impl_->tree = impl_->tree.restricted(keep);  // checks the flags' count
  out.impl_->points.reserve(out.impl_->tree.size());
  for (std::size_t i = 0; i < keep.size(); ++i)
    if (keep[i]) out.impl_->points.push_back(impl_->points[i]);
  return out;
}

bool NearestNeighbourIndex::empty() const { return impl_->points.empty(); }

double NearestNeighbourIndex::distance(const Eigen::Vector3f& p) const {
  return impl_->tree.nearestDistance(p);
}

bool NearestNeighbourIndex::within(const Eigen::Vector3f& p, double radius_m) const {
  return impl_->tree.anyWithin(p, radius_m);
}

void NearestNeighbourIndex::withinIds(const Eigen::Vector3f& p, double radius_m,
                                      std::vector<int>* out) const {
  impl_->tree.within(p, radius_m, out);
}

NearestNeighbourIndex::Neighbourhood NearestNeighbourIndex::neighbourhood(const Eigen::Vector3f& p,
                                                                          double radius_m) const {
  const detail::KnnTree::Moments m = impl_->tree.momentsWithin(p, radius_m);
  Neighbourhood out;
  out.count = static_cast<std::size_t>(m.n);
  if (m.n <= 0.0) return out;
  const Eigen::Vector3d c = Eigen::Vector3d(m.s[0], m.s[1], m.s[2]) / m.n;  // about m.o
  out.centroid = Eigen::Vector3d(m.o[0], m.o[1], m.o[2]) + c;
  Eigen::Matrix3d& cov = out.covariance;
  cov(0, 0) = m.ss[0] / m.n - c.x() * c.x();
  cov(0, 1) = cov(1, 0) = m.ss[1] / m.n - c.x() * c.y();
  cov(0, 2) = cov(2, 0) = m.ss[2] / m.n - c.x() * c.z();
  cov(1, 1) = m.ss[3] / m.n - c.y() * c.y();
  cov(1, 2) = cov(2, 1) = m.ss[4] / m.n - c.y() * c.z();
  cov(2, 2) = m.ss[5] / m.n - c.z() * c.z();
  return out;
}

void NearestNeighbourIndex::prepareMoments() { impl_->tree.buildMoments(); }

std::size_t NearestNeighbourIndex::size() const { return impl_->points.size(); }

double NearestNeighbourIndex::kthDistance(const Eigen::Vector3f& p, int k) const {
  return impl_->tree.kthNearestDistance(p, k);
}

Eigen::Vector3f NearestNeighbourIndex::point(int id) const { return impl_->points[id]; }

std::vector<double> NearestNeighbourIndex::meanNeighbourDistances(int k, int threads,
                                                                  std::vector<double>* kth) const {
  return impl_->tree.meanNeighbourDistances(k, threads, kth);
}

double NearestNeighbourIndex::meanNeighbourDistance(int id, int k, double* kth) const {
  return impl_->tree.meanNeighbourDistance(id, k, kth);
}

}  // namespace novelty_detection
