#include "novelty_detection/sim/world.h"

#include <stdexcept>

namespace novelty_detection {
namespace sim {

void World::add(PrimitivePtr primitive) {
  if (!primitive) throw std::invalid_argument("World::add: null primitive");
  Eigen::AlignedBox3d box = primitive->bounds();
  const bool bounded = box.min().allFinite() && box.max().allFinite();
  if (bounded) box = Eigen::AlignedBox3d(box.min().array() - 1e-9, box.max().array() + 1e-9);
  primitives_.push_back(std::move(primitive));
  bounds_.push_back(box);
  bounded_.push_back(bounded);
}

void World::add(const World& other) {
  for (const auto& p : other.primitives_) add(p);
}

std::optional<Hit> World::intersect(const Ray& ray, double t_max) const {
  std::optional<Hit> best;
  double best_t = t_max;
  for (std::size_t i = 0; i < primitives_.size(); ++i) {
    if (bounded_[i]) {
      double t0, t1;
      if (!rayAabb(ray.origin, ray.dir, bounds_[i].min(), bounds_[i].max(), &t0, &t1) ||
          t0 >= best_t || t1 <= kRayEpsilon)
        continue;
    }
    if (auto t = primitives_[i]->intersect(ray, best_t)) {
      best_t = *t;
      best = Hit{*t, primitives_[i]->objectId()};
    }
  }
  return best;
}

}  // namespace sim
}  // namespace novelty_detection
