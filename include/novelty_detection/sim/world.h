// A set of primitives a ray can hit: the scene one scan sees. ROS-free.
#pragma once

#include <optional>
#include <vector>

#include "novelty_detection/sim/primitives.h"

namespace novelty_detection {
namespace sim {

/// The nearest surface along a ray and the object id of the primitive that owns it.
struct Hit {
  double t = 0.0;     ///< range [m]
  int object_id = 0;  ///< 0 static scene, k > 0 changed object k
};

class World {
 public:
  void add(PrimitivePtr primitive);
  void add(const World& other);

  /// Nearest hit in (kRayEpsilon, t_max) over all primitives, or none. Primitives are
  /// culled by their world bounding boxes first.
  std::optional<Hit> intersect(const Ray& ray, double t_max = kInfinity) const;

  const std::vector<PrimitivePtr>& primitives() const { return primitives_; }
  std::size_t size() const { return primitives_.size(); }

 private:
  std::vector<PrimitivePtr> primitives_;
  std::vector<Eigen::AlignedBox3d> bounds_;
  std::vector<bool> bounded_;
};

}  // namespace sim
}  // namespace novelty_detection
