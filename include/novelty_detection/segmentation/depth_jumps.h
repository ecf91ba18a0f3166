// Depth jumps between pieces of novel points (ROS-free): where the sensor saw one piece in
// front of another along neighbouring rays.
#pragma once

#include <Eigen/Core>

#include <vector>

#include "novelty_detection/types.h"

namespace novelty_detection {

/// A point of piece `far` seen on a ray neighbouring one that ended on piece `near`, and
/// farther along it by more than a depth jump.
struct DepthJump {
  int near = 0;
  int far = 0;
  int far_point = 0;  ///< the far point's index in the cloud
};

/// The depth jumps between `pieces` (disjoint sets of finite points of `cloud`) seen from
/// `origin`: for every point q of one piece and every other piece with a point p on a
/// neighbouring ray (rays closer than `link_radius_m` at p's range: points that far apart
/// across the rays would be linked) nearer than q by more than `jump_m`, one jump (near p's
/// piece, far q's), ordered by far piece and point. One surface cut by the gaps between tilt
/// lines has its pieces on different rays; two objects on the same tilt lines, the nearer
/// hiding part of the other, meet at such jumps, as does a box's top seen past its front edge.
/// With `include` (one flag per piece), only the pieces flagged are looked at.
std::vector<DepthJump> depthJumps(const Cloud& cloud, const std::vector<Indices>& pieces,
                                  const Eigen::Vector3f& origin, double link_radius_m,
                                  double jump_m, const std::vector<char>& include = {});

}  // namespace novelty_detection
