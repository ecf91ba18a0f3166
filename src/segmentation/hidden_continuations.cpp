// Continuations of novel segments into space the reference could not see
// (hidden_segments.h: continuesSegment, growIntoHidden).
#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <deque>
#include <optional>
#include <vector>

#include "novelty_detection/point_grid.h"
#include "novelty_detection/segmentation/hidden_segments.h"
#include "plane_fit.h"

namespace novelty_detection {

using detail::fitPlane;
using detail::Plane;

namespace {

// When at least half of `points` lie within hidden_plane_factor * tau of the plane of
// `segment`'s points around them (within hidden_ring_factor * tau of one of them), they
// continue the segment's own surface: its plane, refitted to those points and them.
std::optional<Plane> continuationPlane(const HiddenSegmentContext& ctx, const Indices& segment,
                                       const Indices& points, const SegmentationParams& params) {
  if (points.empty() || segment.empty() || !ctx.current || !(ctx.tau > 0.0)) return std::nullopt;
  const Cloud& cloud = *ctx.current;
  const double radius = params.hidden.ring_factor * ctx.tau;
  Points3d pts;
  pts.reserve(points.size());
  for (int i : points) pts.push_back(cloud[i].getVector3fMap().cast<double>());
  const PointGrid grid(pts, radius);
  Indices near;  // the segment's points around them
  for (int i : segment) {
    bool close = false;
    grid.forNeighbours(cloud[i].getVector3fMap().cast<double>(), radius,
                       [&](int) { close = true; });
    if (close) near.push_back(i);
  }
  if (near.size() < 3) return std::nullopt;
  const Plane plane = fitPlane(cloud, near);
  const double on_plane = params.hidden.plane_factor * ctx.tau;
  Indices on = near;  // refitted with the points on it: the surface over both
  for (std::size_t k = 0; k < pts.size(); ++k)
    if (std::abs(plane.normal.dot(pts[k] - plane.centroid)) <= on_plane) on.push_back(points[k]);
  if (2 * (on.size() - near.size()) < points.size()) return std::nullopt;
  return fitPlane(cloud, on);
}

// Past the cap of growIntoHidden, for a segment whose continuation goes on in its own surface
// (`plane`: a leaf the map saw a part of): the candidates on that plane join too, breadth
// first over links from the segment and its continuation `added`, except where the map's own
// surface (its structure still there) runs on in the plane (a wall the leaf nearly closes
// against, seen from a shifted pose).
void growAlongPlane(const Cloud& current, const PointGrid& grid, const Points3d& pts,
                    const Indices& free, const Indices& seg, const Plane& plane,
                    const HiddenSegmentContext& ctx, const SegmentationParams& params,
                    double link_radius_m, std::vector<char>* used, Indices* added) {
  const double on_plane = params.hidden.plane_factor * ctx.tau;
  const auto off_plane = [&](const Eigen::Vector3d& x) {
    return std::abs(plane.normal.dot(x - plane.centroid)) > on_plane;
  };
  std::vector<int> ids;
  const auto on_mapped_surface = [&](const Eigen::Vector3d& q) {
    if (!ctx.structure) return false;
    ids.clear();
    ctx.structure->withinIds(q.cast<float>(), kLocalPlaneFactor * ctx.tau, &ids);
    for (int id : ids) {
      if (ctx.goneAt(id)) continue;
      if (!off_plane(ctx.structure->point(id).cast<double>())) return true;
    }
    return false;
  };
  std::deque<Eigen::Vector3d> frontier;
  for (int i : seg) frontier.push_back(current[i].getVector3fMap().cast<double>());
  for (int i : *added) frontier.push_back(current[i].getVector3fMap().cast<double>());
  while (!frontier.empty()) {
    const Eigen::Vector3d p = frontier.front();
    frontier.pop_front();
    grid.forNeighbours(p, link_radius_m, [&](int k) {
      const Eigen::Vector3d& q = pts[static_cast<std::size_t>(k)];
      if ((*used)[static_cast<std::size_t>(k)] || off_plane(q) || on_mapped_surface(q)) return;
      (*used)[static_cast<std::size_t>(k)] = 1;
      added->push_back(free[static_cast<std::size_t>(k)]);
      frontier.push_back(q);
    });
  }
}

}  // namespace

bool continuesSegment(const HiddenSegmentContext& ctx, const Indices& segment,
                      const Indices& points, const SegmentationParams& params) {
  return continuationPlane(ctx, segment, points, params).has_value();
}

void growIntoHidden(const Cloud& current, std::vector<Indices>* segments, const Indices& hidden,
                    double link_radius_m, double max_growth, const HiddenSegmentContext* revealed,
                    const SegmentationParams* params) {
  if (!segments || segments->empty() || hidden.empty() || !(link_radius_m > 0.0) ||
      !std::isfinite(link_radius_m)) {
    return;
  }
  std::vector<char> taken_by_segment(current.size(), 0);
  for (const Indices& s : *segments)
    for (int i : s) taken_by_segment[static_cast<std::size_t>(i)] = 1;
  Indices free;
  Points3d pts;
  for (int i : hidden) {
    if (taken_by_segment[static_cast<std::size_t>(i)]) continue;
    free.push_back(i);
    pts.push_back(current[i].getVector3fMap().cast<double>());
  }
  if (free.empty()) return;
  const PointGrid grid(pts, link_radius_m);
  std::vector<char> used(free.size(), 0);
  for (Indices& seg : *segments) {
    // Breadth first from the segment's points (nearest links first), up to the cap.
    const std::size_t cap = static_cast<std::size_t>(max_growth * static_cast<double>(seg.size()));
    std::deque<Eigen::Vector3d> frontier;
    for (int i : seg) frontier.push_back(current[i].getVector3fMap().cast<double>());
    Indices added;
    while (!frontier.empty() && added.size() < cap) {
      const Eigen::Vector3d p = frontier.front();
      frontier.pop_front();
      grid.forNeighbours(p, link_radius_m, [&](int k) {
        if (used[static_cast<std::size_t>(k)] || added.size() >= cap) return;
        used[static_cast<std::size_t>(k)] = 1;
        added.push_back(free[static_cast<std::size_t>(k)]);
        frontier.push_back(pts[static_cast<std::size_t>(k)]);
      });
    }
    if (added.empty()) continue;
    const std::optional<Plane> own =
        revealed && params ? continuationPlane(*revealed, seg, added, *params) : std::nullopt;
    if (revealed && params && !own && revealedSurface(*revealed, added, *params)) continue;
    if (own)
      growAlongPlane(current, grid, pts, free, seg, *own, *revealed, *params, link_radius_m, &used,
                     &added);
    seg.insert(seg.end(), added.begin(), added.end());
    std::sort(seg.begin(), seg.end());
  }
}

}  // namespace novelty_detection
