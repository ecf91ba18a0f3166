// What a far or partly hidden object's view says (shape/fit_bounds.h): whether a segment
// whose lowest line was taken for the floor, or whose underside is hidden, rests on it, the
// hidden lower part of the latter, and the axis a round object's sections are circles about.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "novelty_detection/point_grid.h"
#include "novelty_detection/shape/fit_bounds.h"
#include "novelty_detection/shape/superquadric_fit.h"
#include "novelty_detection/visibility/visibility.h"

namespace novelty_detection {
namespace {
// Steps of the search for free space beneath a segment's lowest points [m] (at least).
constexpr double kRestStepM = 0.02;
// Gauss-Newton iterations of the section circles' axis (it converges in a few).
constexpr int kCircleIterations = 20;
}  // namespace

bool restsOnFloor(const Points3d& segment, const Points3d& floor_points, const Points3d& others,
                  double spacing, const FitBounds& bounds, double* lowest_height_m,
                  FloorSupport* support) {
  if (support) *support = FloorSupport::kNone;
  if (!bounds.has_floor || !bounds.view || segment.empty()) return false;
  double low, high;
  bounds.heightRange(segment, &low, &high);
  if (lowest_height_m) *lowest_height_m = low;
  const double band_top = low + std::max(2.0 * spacing, kRestBand * (high - low));
  Points3d bottom;
  for (const auto& p : segment)
    if (bounds.heightAboveFloor(p) <= band_top) bottom.push_back(p);
  bottom = subsample(bottom, kRestColumns);
  const double step = std::max(bounds.margin_m, kRestStepM);
  const double reach = std::max(bounds.margin_m, 2.0 * spacing);
  if (!(reach > 0.0)) return false;
  // The floor returns on the floor plan, indexed for the search within reach.
  const auto on_plan = [&](const Eigen::Vector3d& p) -> Eigen::Vector3d {
    return p - bounds.up.dot(p) * bounds.up;
  };
  Points3d plan;
  plan.reserve(floor_points.size());
  for (const auto& f : floor_points) plan.push_back(on_plan(f));
  const PointGrid floor_grid(plan, reach);
  // The sweep's other returns above the floor, on the floor plan (their heights kept apart).
  Points3d other_plan;
  std::vector<double> other_height;
  other_plan.reserve(others.size());
  other_height.reserve(others.size());
  for (const auto& o : others) {
    other_plan.push_back(on_plan(o));
    other_height.push_back(bounds.heightAboveFloor(o));
  }
  const PointGrid other_grid(other_plan, reach);
  int seen_beneath = 0, floor_at_foot = 0, hidden_beneath = 0;
  for (const auto& p : bottom) {
    const double h = bounds.heightAboveFloor(p);
    // Seen through beneath (any ray of the 3 x 3 window passed below it), and, by each
    // sample's own cell, seen through or hidden (behind what the sweep saw, or not looked at).
    bool free = false, through = false, hidden = false;
    for (double d = step; h - d > bounds.floor_band_m; d += step) {
      const Eigen::Vector3f q = (p - d * bounds.up).cast<float>();
      if (!free && bounds.view->classify(q, bounds.margin_m) == Visibility::kFree) free = true;
      const Visibility own =
          bounds.view->classify(q, bounds.margin_m, RangeImage::Neighbourhood::kOwnCell);
      through = through || own == Visibility::kFree;
      hidden = hidden || own == Visibility::kOccluded || own == Visibility::kUnknown;
    }
    seen_beneath += free;
    const Eigen::Vector3d foot = on_plan(p);
    if (floor_grid.nearest(foot) >= 0) {
      ++floor_at_foot;
      continue;
    }
    if (free || through || !hidden) continue;
    // Hidden beneath: nothing the sweep returned lies under the point (no table, no shelf).
    bool below = false;
    other_grid.forNeighbours(foot, reach, [&](int j) {
      below = below || other_height[static_cast<std::size_t>(j)] < h - step;
    });
    hidden_beneath += !below;
  }
  const double n = static_cast<double>(bottom.size());
  const bool rests =
      seen_beneath <= kMaxSeenBeneath * n && floor_at_foot + hidden_beneath >= kMinFloorAtFoot * n;
  if (rests && support)
    *support = floor_at_foot >= hidden_beneath ? FloorSupport::kFloorAtFoot : FloorSupport::kHidden;
  return rests;
}

Points3d extrudedToFloor(const Points3d& points, const FitBounds& bounds) {
  // Points that come down to the floor themselves, or that do not hold the segment's bottom
  // (a part above another one: it does not stand on the floor), have no hidden part below.
  if (!bounds.hidden_beneath || !bounds.has_floor || points.size() < 2) return {};
  double lo, hi;
  bounds.heightRange(points, &lo, &hi);
  if (bounds.comesDownFrom(lo, hi) || !bounds.standsFrom(lo, hi)) return {};
  const double step = std::max(2.0 * medianSpacing(points), kRestBand * (hi - lo));
  if (!(step > 0.0)) return {};
  Points3d band;
  for (const auto& p : points)
    if (bounds.heightAboveFloor(p) < lo + step) band.push_back(p);
  Points3d out;
  for (double down = step; lo - down >= 0.0; down += step)
    for (const auto& p : band) out.push_back(p - down * bounds.up);
  // As densely per height as the points themselves (a scanner's lines lie farther apart
  // than its points along them): the seen part keeps its weight in the fit.
  const double per_height = static_cast<double>(points.size()) / std::max(hi - lo, step);
  return subsample(out, static_cast<int>(std::lround(per_height * lo)));
}

bool sectionCirclesCentre(const Points3d& points, const Eigen::Vector3d& up,
                          const Eigen::Vector3d& start, Eigen::Vector3d* centre) {
  if (points.size() < 3) return false;
  // Floor-plan coordinates (x, y) and the height band of each point.
  const Eigen::Vector3d ex = up.unitOrthogonal(), ey = up.cross(ex);
  double z_lo = std::numeric_limits<double>::infinity(), z_hi = -z_lo;
  for (const auto& p : points) {
    z_lo = std::min(z_lo, up.dot(p));
    z_hi = std::max(z_hi, up.dot(p));
  }
  const double band_height = std::max(1e-9, (z_hi - z_lo) / kSectionBands);
  std::vector<int> band(points.size());
  std::vector<Eigen::Vector2d> xy(points.size());
  std::array<double, kSectionBands> count{};
  for (std::size_t i = 0; i < points.size(); ++i) {
    band[i] =
        std::min(kSectionBands - 1, static_cast<int>((up.dot(points[i]) - z_lo) / band_height));
    xy[i] = Eigen::Vector2d(ex.dot(points[i]), ey.dot(points[i]));
    count[static_cast<std::size_t>(band[i])] += 1.0;
  }
  Eigen::Vector2d c(ex.dot(start), ey.dot(start));
  std::vector<Eigen::Vector2d> dir(points.size());
  std::vector<double> dist(points.size());
  for (int it = 0; it < kCircleIterations; ++it) {
    // Residual d_i - mean of its band, whose derivative is the unit direction's deviation
    // from its band's mean: the radii are eliminated.
    std::array<Eigen::Vector2d, kSectionBands> dir_mean;
    std::array<double, kSectionBands> dist_mean{};
    for (auto& m : dir_mean) m.setZero();
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector2d d = xy[i] - c;
      dist[i] = d.norm();
      dir[i] = dist[i] > 1e-12 ? Eigen::Vector2d(d / dist[i]) : Eigen::Vector2d::Zero();
      const auto b = static_cast<std::size_t>(band[i]);
      dir_mean[b] += dir[i] / count[b];
      dist_mean[b] += dist[i] / count[b];
    }
    Eigen::Matrix2d jtj = Eigen::Matrix2d::Zero();
    Eigen::Vector2d jtr = Eigen::Vector2d::Zero();
    for (std::size_t i = 0; i < points.size(); ++i) {
      const auto b = static_cast<std::size_t>(band[i]);
      if (count[b] < 3.0) continue;  // a band of one or two points fixes no circle
      const Eigen::Vector2d j = -(dir[i] - dir_mean[b]);
      jtj += j * j.transpose();
      jtr += j * (dist[i] - dist_mean[b]);
    }
    if (jtj.determinant() <= 1e-12 * (jtj.trace() * jtj.trace() + 1e-30)) return false;
    const Eigen::Vector2d step = jtj.ldlt().solve(-jtr);
    if (!step.allFinite()) return false;
    c += step;
    if (step.norm() < 1e-6) break;
  }
  *centre = c.x() * ex + c.y() * ey;
  return c.allFinite();
}

}  // namespace novelty_detection
