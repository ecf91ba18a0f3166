#include "novelty_detection/segmentation/depth_jumps.h"

#include "common/knn.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <tuple>

namespace novelty_detection {
namespace {

/// One piece seen from the origin: its points' rays (unit directions), ranges and cloud
/// indices, the box around the rays, and an index over them.
struct PieceRays {
  std::vector<Eigen::Vector3f> rays;
  std::vector<float> range;
  std::vector<int> index;
  Eigen::AlignedBox3f box;
  detail::KnnTree tree;
};

}  // namespace

std::vector<DepthJump> depthJumps(const Cloud& cloud, const std::vector<Indices>& pieces,
                                  const Eigen::Vector3f& origin, double link_radius_m,
                                  double jump_m, const std::vector<char>& include) {
  std::vector<DepthJump> out;
  if (pieces.size() < 2 || !(link_radius_m > 0.0)) return out;
  std::vector<PieceRays> seen(pieces.size());
  for (std::size_t a = 0; a < pieces.size(); ++a) {
    if (!include.empty() && !include[a]) continue;
    PieceRays& s = seen[a];
    for (int i : pieces[a]) {
      const Eigen::Vector3f d = cloud[i].getVector3fMap() - origin;
      const float r = d.norm();
      if (!(r > 0.f) || !std::isfinite(r)) continue;
      s.rays.push_back(d / r);
      s.range.push_back(r);
      s.index.push_back(i);
      s.box.extend(s.rays.back());
    }
    if (!s.rays.empty()) s.tree = detail::KnnTree(s.rays);
  }
  // Each point p as the nearer one: the other pieces' points on rays within link_radius_m of
  // p's at p's range, more than jump_m farther. Only pieces whose rays come that close are
  // searched, so the inside of a piece costs one box test per other piece.
  std::vector<std::tuple<int, int, int>> found;  // (far piece, far point, near piece)
  std::vector<int> near;
  for (std::size_t a = 0; a < seen.size(); ++a) {
    const PieceRays& sa = seen[a];
    for (std::size_t k = 0; k < sa.rays.size(); ++k) {
      const float w = static_cast<float>(link_radius_m) / sa.range[k];
      for (std::size_t b = 0; b < seen.size(); ++b) {
        const PieceRays& sb = seen[b];
        if (b == a || sb.rays.empty() || sb.box.exteriorDistance(sa.rays[k]) > w) continue;
        near.clear();
        sb.tree.within(sa.rays[k], w, &near);
        for (int q : near)
          if (sb.range[q] - sa.range[k] > jump_m)
            found.emplace_back(static_cast<int>(b), q, static_cast<int>(a));
      }
    }
  }
  std::sort(found.begin(), found.end());
  found.erase(std::unique(found.begin(), found.end()), found.end());
  for (const auto& [b, q, a] : found) out.push_back({a, b, seen[b].index[q]});
  return out;
}

}  // namespace novelty_detection
