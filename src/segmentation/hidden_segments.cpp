#include "novelty_detection/segmentation/hidden_segments.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <set>
#include <tuple>

#include "plane_fit.h"

namespace novelty_detection {
namespace {

using detail::fitPlane;
using detail::Plane;

// Test 2 on the surface of `points` points (surfacePlane below: `surface` of them on it, its
// plane's spreads): most of them on it, a plane (wide enough, flatter across than along it)
// and noise-sized thickness.
bool surfacePatch(std::size_t points, std::size_t surface, double width_m, double thickness_m,
                  double tau) {
  return surface >= kMinSurfaceShare * points && width_m >= kMinPatchWidth * tau &&
         thickness_m < kMaxLocalFlatness * width_m && !(thickness_m > tau);
}

// The plane of a segment's surface (test 2): the plane of all its points when they are no
// thicker than tau (`on`: all of them); else refitted kSurfaceRounds times to the
// kSurfaceTrim share of them nearest the last plane, its points those within
// kSurfaceBand * tau of it (`on`, ascending), its spreads theirs. A few stray points linked
// across a gap between tilt lines (far wall returns above a leaf) then neither tilt the plane
// nor thicken it.
Plane surfacePlane(const Cloud& cloud, const Indices& points, double tau, Indices* on) {
  Plane plane = fitPlane(cloud, points);
  if (!(plane.sd(0) > tau)) {  // thin as a whole: all of it is the surface
    *on = points;
    return plane;
  }
  std::vector<std::pair<double, int>> off(points.size());
  const auto measure = [&] {
    for (std::size_t k = 0; k < points.size(); ++k) {
      const Eigen::Vector3d p = cloud[points[k]].getVector3fMap().cast<double>();
      off[k] = {std::abs(plane.normal.dot(p - plane.centroid)), points[k]};
    }
  };
  const std::size_t keep =
      std::max<std::size_t>(3, static_cast<std::size_t>(kSurfaceTrim * points.size()));
  Indices near;
  for (int round = 0; round < kSurfaceRounds && keep < points.size(); ++round) {
    measure();
    std::nth_element(off.begin(), off.begin() + (keep - 1), off.end());
    near.clear();
    for (std::size_t k = 0; k < keep; ++k) near.push_back(off[k].second);
    plane = fitPlane(cloud, near);
  }
  measure();
  on->clear();
  for (const auto& [d, i] : off)
    if (d <= kSurfaceBand * tau) on->push_back(i);
  std::sort(on->begin(), on->end());
  if (on->size() >= 3) plane = fitPlane(cloud, *on);
  return plane;
}

// Test 3's verdict: structure around, and enough of it on the segment's plane.
bool continuesMap(const HiddenSegmentEvidence& e, const SegmentationParams& params) {
  return e.ring > 0 && e.ring_coplanar >= params.hidden.max_coplanar * e.ring;
}

// The cell of side `size` holding p, as a key (the cell itself: a hashed key could collide).
using CellKey = std::tuple<long long, long long, long long>;
CellKey cellOf(const Eigen::Vector3f& p, double size) {
  const Eigen::Vector3d c = (p.cast<double>() / size).array().floor();
  return {static_cast<long long>(c.x()), static_cast<long long>(c.y()),
          static_cast<long long>(c.z())};
}

using Neighbourhood = NearestNeighbourIndex::Neighbourhood;

// `given` (goneIndex(structure, gone) made by a caller), else that index made into `own`.
const NearestNeighbourIndex* goneIndexOf(const NearestNeighbourIndex* given,
                                         const NearestNeighbourIndex& structure,
                                         const std::vector<std::uint8_t>& gone,
                                         NearestNeighbourIndex* own) {
  if (given) return given;
  *own = goneIndex(structure, gone);
  return own;
}

// The structure within r of q less its disappeared points (`gone`: those alone; null or
// empty: none), from both indices' moments.
Neighbourhood stillThere(const NearestNeighbourIndex& structure, const NearestNeighbourIndex* gone,
                         const Eigen::Vector3f& q, double r) {
  const Neighbourhood all = structure.neighbourhood(q, r);
  if (!gone || gone->empty() || all.count == 0) return all;
  const Neighbourhood left = gone->neighbourhood(q, r);
  if (left.count == 0) return all;
  Neighbourhood out;
  if (left.count >= all.count) return out;
  out.count = all.count - left.count;
  const double na = static_cast<double>(all.count), ng = static_cast<double>(left.count);
  const double n = static_cast<double>(out.count);
  // Sums about the whole neighbourhood's centroid: the gone points' offsets are small there.
  const Eigen::Vector3d dg = left.centroid - all.centroid;
  const Eigen::Vector3d sum = -ng * dg;  // the whole's sum about its centroid is zero
  const Eigen::Matrix3d outer = na * all.covariance - ng * (left.covariance + dg * dg.transpose());
  const Eigen::Vector3d c = sum / n;
  out.centroid = all.centroid + c;
  out.covariance = outer / n - c * c.transpose();
  return out;
}

// The structure's own surface around a point, against a segment's plane (test 3): a plane
// parallel to it, another plane, or another plane that runs on into structure that
// disappeared (what is left of a surface that moved: the old leaf about the new one's hinge).
enum class LocalSurface { kUnknown, kParallel, kOther, kLeftBehind };

// Test 3: reference structure around the segment, and how much of it lies on its plane. The
// segment is queried at one point per voxel of half the ring radius (the ring is the
// structure within ring_factor * tau of those points), so the cost follows its area / tau^2.
void measureRing(const HiddenSegmentContext& ctx, const Indices& segment, const Plane& plane,
                 const SegmentationParams& params, HiddenSegmentEvidence* e) {
  std::set<CellKey> voxels;
  std::vector<int> ids;
  std::vector<char> seen;
  const double radius = params.hidden.ring_factor * ctx.tau;
  const double on_plane = params.hidden.plane_factor * ctx.tau;
  const double beside = params.hidden.parallel_factor * ctx.tau;
  const double min_cos = std::cos(kParallelDeg * M_PI / 180.0);
  NearestNeighbourIndex own_gone;
  const NearestNeighbourIndex* gone_points =
      ctx.gone ? goneIndexOf(ctx.gone_points, *ctx.structure, *ctx.gone, &own_gone) : nullptr;
  // The surface of the structure around point `id` against the segment's plane, measured
  // once per cell of tau (at the first point asked in it).
  std::map<CellKey, LocalSurface> surface_in;
  std::vector<int> gone_ids;
  const auto surface = [&](int id) {
    const Eigen::Vector3f q = ctx.structure->point(id);
    const auto [it, added] = surface_in.emplace(cellOf(q, ctx.tau), LocalSurface::kUnknown);
    if (!added) return it->second;
    // Of the structure that is still there (all of it less what disappeared): a disappeared
    // leaf beside a wall is no part of the wall's surface.
    const auto plane_within = [&](double r) {
      const Neighbourhood still = stillThere(*ctx.structure, gone_points, q, r);
      if (still.count < static_cast<std::size_t>(kMinLocalPoints)) return std::optional<Plane>();
      const Plane local = detail::planeOf(still.centroid, still.covariance);
      if (!(local.sd(0) < kMaxLocalFlatness * local.sd(1)) ||
          !(local.sd(1) >= kMinLocalWidth * ctx.tau))
        return std::optional<Plane>();
      return std::optional<Plane>(local);
    };
    const double r = kLocalPlaneFactor * ctx.tau;
    std::optional<Plane> local = plane_within(r);
    if (!local && 2.0 * r <= radius) local = plane_within(2.0 * r);
    if (!local) return it->second;
    if (std::abs(local->normal.dot(plane.normal)) >= min_cos) {
      it->second = LocalSurface::kParallel;
      return it->second;
    }
    // Left behind when its own plane runs on into disappeared structure within the ring.
    it->second = LocalSurface::kOther;
    if (!gone_points || gone_points->empty()) return it->second;
    gone_ids.clear();
    gone_points->withinIds(q, radius, &gone_ids);
    for (int j : gone_ids) {
      if (std::abs(local->normal.dot(gone_points->point(j).cast<double>() - local->centroid)) <=
          on_plane) {
        it->second = LocalSurface::kLeftBehind;
        break;
      }
    }
    return it->second;
  };
  const double voxel = std::max(0.5 * radius, 1e-3);
  for (int i : segment) {
    const Eigen::Vector3f p = (*ctx.current)[i].getVector3fMap();
    if (!voxels.insert(cellOf(p, voxel)).second) continue;
    ids.clear();
    ctx.structure->withinIds(p, radius, &ids);
    for (int id : ids) {
      if (id >= static_cast<int>(seen.size())) seen.resize(id + 1, 0);
      if (seen[id]) continue;
      seen[id] = 1;
      if (ctx.goneAt(id)) continue;
      ++e->ring;
      const Eigen::Vector3d q = ctx.structure->point(id).cast<double>();
      const double off = std::abs(plane.normal.dot(q - plane.centroid));
      if (off <= on_plane) {
        // What is left of a surface that moved and crosses the segment's plane (the old leaf
        // about the new one's hinge) lies on it only along the line where they meet.
        if (surface(id) != LocalSurface::kLeftBehind) ++e->ring_coplanar;
      } else if (off <= beside && surface(id) == LocalSurface::kParallel) {
        ++e->ring_coplanar;
        ++e->ring_parallel;
      }
    }
  }
}

// Test 4: the current sweep's rays around the segment's outline against its plane.
void measureOutline(const HiddenSegmentContext& ctx, const Indices& segment, const Plane& plane,
                    const SegmentationParams& params, HiddenSegmentEvidence* e) {
  const RangeImage& image = *ctx.current_image;
  const int cols = image.cols();
  const std::vector<RayCell> own_rays =
      ctx.rays ? std::vector<RayCell>() : rayCells(*ctx.current, image);
  const std::vector<RayCell>& rays = ctx.rays ? *ctx.rays : own_rays;
  int col0 = -1;
  // Columns relative to the segment's first one, in (-cols/2, cols/2]: no seam at +-pi.
  auto unwrap = [&](int col) {
    const int dc = ((col - col0) % cols + cols) % cols;
    return dc > cols / 2 ? dc - cols : dc;
  };
  std::vector<std::pair<int, int>> cells;  // (unwrapped column, row) of the segment's points
  std::vector<float> ranges;
  for (int i : segment) {
    const RayCell& ray = rays[static_cast<std::size_t>(i)];
    if (ray.col < 0) continue;
    if (col0 < 0) col0 = ray.col;
    cells.emplace_back(unwrap(ray.col), ray.row);
    ranges.push_back(ray.range);
  }
  if (ranges.empty()) return;
  std::nth_element(ranges.begin(), ranges.begin() + ranges.size() / 2, ranges.end());
  const double range = std::max<double>(ranges[ranges.size() / 2], 1e-3);
  // Ring width in cells, bounded (a degenerate tau must not make the grid below huge).
  const double k_max = std::max(1, std::min(cols, image.rows()) / 8);
  const double k_cells =
      std::ceil(params.hidden.outline_factor * ctx.tau / (range * std::max(image.cellRad(), 1e-9)));
  const int k = static_cast<int>(std::isfinite(k_cells) ? std::clamp(k_cells, 1.0, k_max) : k_max);
  // The segment's cells on a local grid padded by k, dilated by a (2k+1)^2 box (summed-area
  // table): the ring is the dilation minus the segment's own cells.
  int c_lo = cells[0].first, c_hi = c_lo, r_lo = cells[0].second, r_hi = r_lo;
  for (const auto& [c, r] : cells) {
    c_lo = std::min(c_lo, c), c_hi = std::max(c_hi, c);
    r_lo = std::min(r_lo, r), r_hi = std::max(r_hi, r);
  }
  const int w = c_hi - c_lo + 1 + 2 * k, h = r_hi - r_lo + 1 + 2 * k;
  if (static_cast<double>(w) * h > 4.0 * cols * image.rows()) return;  // no useful outline
  std::vector<char> own(static_cast<std::size_t>(w) * h, 0);
  for (const auto& [c, r] : cells)
    own[static_cast<std::size_t>(r - r_lo + k) * w + (c - c_lo + k)] = 1;
  std::vector<int> sat(static_cast<std::size_t>(w + 1) * (h + 1), 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      sat[static_cast<std::size_t>(y + 1) * (w + 1) + x + 1] =
          own[static_cast<std::size_t>(y) * w + x] +
          sat[static_cast<std::size_t>(y) * (w + 1) + x + 1] +
          sat[static_cast<std::size_t>(y + 1) * (w + 1) + x] -
          sat[static_cast<std::size_t>(y) * (w + 1) + x];
  auto boxSum = [&](int x0, int y0, int x1, int y1) {  // inclusive, clamped
    x0 = std::max(x0, 0), y0 = std::max(y0, 0), x1 = std::min(x1, w - 1), y1 = std::min(y1, h - 1);
    return sat[static_cast<std::size_t>(y1 + 1) * (w + 1) + x1 + 1] -
           sat[static_cast<std::size_t>(y0) * (w + 1) + x1 + 1] -
           sat[static_cast<std::size_t>(y1 + 1) * (w + 1) + x0] +
           sat[static_cast<std::size_t>(y0) * (w + 1) + x0];
  };
  std::vector<char> in_ring(static_cast<std::size_t>(w) * h, 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      in_ring[static_cast<std::size_t>(y) * w + x] =
          !own[static_cast<std::size_t>(y) * w + x] && boxSum(x - k, y - k, x + k, y + k) > 0;
  const Eigen::Vector3f& o = image.origin();
  const double offset = plane.normal.dot(plane.centroid - o.cast<double>());
  for (std::size_t i = 0; i < rays.size(); ++i) {
    const RayCell& ray = rays[i];
    if (ray.col < 0) continue;
    const int x = unwrap(ray.col) - c_lo + k, y = ray.row - r_lo + k;
    if (x < 0 || y < 0 || x >= w || y >= h || !in_ring[static_cast<std::size_t>(y) * w + x])
      continue;
    const Eigen::Vector3d dir = ((*ctx.current)[i].getVector3fMap() - o).cast<double>() / ray.range;
    const double nu = plane.normal.dot(dir);
    if (std::abs(nu) < 1e-3) continue;  // the ray runs along the plane
    const double t = offset / nu;       // range at which the ray meets the plane
    if (t <= 0 || ray.range > t + ctx.margin_m) {
      ++e->past;
    } else if (ray.range >= t - ctx.margin_m) {
      ++e->on;
    }
  }
}

}  // namespace

NearestNeighbourIndex goneIndex(const NearestNeighbourIndex& structure,
                                const std::vector<std::uint8_t>& gone) {
  Cloud points;
  const std::size_t n = std::min(gone.size(), structure.size());
  for (std::size_t j = 0; j < n; ++j) {
    if (!gone[j]) continue;
    const Eigen::Vector3f p = structure.point(static_cast<int>(j));
    points.push_back(PointT(p.x(), p.y(), p.z()));
  }
  NearestNeighbourIndex index;
  if (!points.empty()) index.build(points);
  return index;
}

std::vector<RayCell> rayCells(const Cloud& cloud, const RangeImage& image) {
  std::vector<RayCell> out(cloud.size());
  if (image.empty()) return out;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f d = cloud[i].getVector3fMap() - image.origin();
    RayCell c;
    if (d.allFinite() && image.cellOf(d, &c.col, &c.row, &c.range) && c.range > 0.f) out[i] = c;
  }
  return out;
}

HiddenSegmentEvidence measureHiddenSegment(const HiddenSegmentContext& ctx, const Indices& segment,
                                           const std::vector<Visibility>& vis,
                                           const SegmentationParams& params, Indices* on_surface) {
  HiddenSegmentEvidence e;
  e.points = static_cast<int>(segment.size());
  for (Visibility v : vis) e.occluded += v == Visibility::kOccluded;
  if (segment.size() < 3 || !ctx.current) return e;
  Indices own;
  Indices& surface = on_surface ? *on_surface : own;
  const Plane plane = surfacePlane(*ctx.current, segment, ctx.tau, &surface);
  e.surface = static_cast<int>(surface.size());
  e.width_m = plane.sd(1);
  e.thickness_m = plane.sd(0);
  if (ctx.structure) measureRing(ctx, surface, plane, params, &e);
  if (ctx.current_image && !ctx.current_image->empty()) {
    e.origin_offset_m =
        std::abs(plane.normal.dot(plane.centroid - ctx.current_image->origin().cast<double>()));
    measureOutline(ctx, surface, plane, params, &e);
  }
  return e;
}

bool hiddenSegmentIsNovel(const HiddenSegmentEvidence& e, double tau,
                          const SegmentationParams& params) {
  if (2 * e.occluded < e.points) return false;                              // 1
  if (!surfacePatch(e.points, e.surface, e.width_m, e.thickness_m, tau) ||  // 2
      (e.origin_offset_m >= 0.0 && !(e.origin_offset_m > tau)))
    return false;
  if (e.ring == 0 || continuesMap(e, params)) return false;  // 3
  const int outline = e.past + e.on;                         // 4
  return outline > 0 && e.past >= params.hidden.min_free_edge * outline;
}

std::vector<Indices> novelHiddenSegments(const Cloud& current, const Indices& hidden,
                                         const std::vector<int>& hidden_owner,
                                         const std::vector<Visibility>& hidden_vis,
                                         int num_gaussians, const NearestNeighbourIndex& structure,
                                         const std::vector<std::uint8_t>& gone, double tau,
                                         const Params& params, const RangeImage* current_image,
                                         const NearestNeighbourIndex* gone_points) {
  std::vector<Indices> out;
  const Eigen::Vector3f origin = current.sensor_origin_.head<3>();
  if (hidden.empty() || !sensorOriginKnown(current.sensor_origin_)) return out;
  const std::vector<Indices> segments =
      segmentNovelPoints(current, hidden, hidden_owner, num_gaussians, params.segmentation);
  if (segments.empty()) return out;
  RangeImage own;  // the current sweep from its own origin (test 4)
  if (!current_image) own.build(current, {}, origin, rangeImageConfig(params.visibility));
  const RangeImage& image = current_image ? *current_image : own;
  HiddenSegmentContext ctx;
  ctx.current = &current;
  ctx.structure = &structure;
  ctx.gone = &gone;
  NearestNeighbourIndex own_gone;
  ctx.gone_points = goneIndexOf(gone_points, structure, gone, &own_gone);
  ctx.current_image = &image;
  const std::vector<RayCell> rays = rayCells(current, image);
  ctx.rays = &rays;
  ctx.tau = tau;
  ctx.margin_m = params.visibility.margin_factor * tau;
  for (const Indices& seg : segments) {
    std::vector<Visibility> vis;
    vis.reserve(seg.size());
    for (int i : seg)
      vis.push_back(hidden_vis[std::lower_bound(hidden.begin(), hidden.end(), i) - hidden.begin()]);
    Indices surface;
    const HiddenSegmentEvidence e =
        measureHiddenSegment(ctx, seg, vis, params.segmentation, &surface);
    if (hiddenSegmentIsNovel(e, tau, params.segmentation)) out.push_back(surface);
  }
  return out;
}

bool revealedSurface(const HiddenSegmentContext& ctx, const Indices& points,
                     const SegmentationParams& params) {
  if (points.size() < 3 || !ctx.current || !ctx.structure) return false;
  Indices surface;
  const Plane plane = surfacePlane(*ctx.current, points, ctx.tau, &surface);
  if (!surfacePatch(points.size(), surface.size(), plane.sd(1), plane.sd(0), ctx.tau)) return false;
  HiddenSegmentEvidence e;
  measureRing(ctx, surface, plane, params, &e);
  return continuesMap(e, params);
}

}  // namespace novelty_detection
