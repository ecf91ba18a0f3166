#include "novelty_detection/shape/fit_bounds.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "novelty_detection/point_grid.h"
#include "novelty_detection/preprocess/range_noise.h"
#include "novelty_detection/shape/superquadric_fit.h"
#include "novelty_detection/visibility/visibility.h"

namespace novelty_detection {
namespace {
// Free-space samples per segment: the grid over the inflated box has about this many cells.
constexpr double kGridCells = 4096.0;
// The box about a segment is inflated by this fraction of its largest extent on every side
// (a fit's sizes and centre are bounded to about that reach, superquadric/max_size_factor).
constexpr double kInflate = 0.5;
// An axis within about 8 degrees of up is the upright axis of a fit.
constexpr double kUprightCos = 0.99;
// Shape exponent of a sharp corner (the fit's lower bound by default).
constexpr double kCornerExponent = 0.1;
// The silhouette's ends: this share of its width at each side.
constexpr double kEndBand = 0.02;
// Steps of the search for the first free space above a fit's top [m] (at least).
constexpr double kGapStepM = 0.01;
}  // namespace

void FitBounds::heightRange(const Points3d& points, double* lo, double* hi) const {
  *lo = std::numeric_limits<double>::infinity();
  *hi = -*lo;
  for (const auto& p : points) {
    const double h = heightAboveFloor(p);
    *lo = std::min(*lo, h);
    *hi = std::max(*hi, h);
  }
}

bool FitBounds::comesDownFrom(double lo, double hi) const {
  return lo <= floor_band_m + params.support_fraction * (hi - lo);
}

bool FitBounds::standsFrom(double lo, double hi) const {
  return comesDownFrom(lo, hi) ||
         (rests_on_floor && lo <= lowest_height_m + std::max(floor_band_m, margin_m));
}

bool FitBounds::comesDownToFloor(const Points3d& points) const {
  if (!has_floor || points.empty()) return false;
  double lo, hi;
  heightRange(points, &lo, &hi);
  return comesDownFrom(lo, hi);
}

bool FitBounds::standsOnFloor(const Points3d& points) const {
  if (!has_floor || points.empty()) return false;
  double lo, hi;
  heightRange(points, &lo, &hi);
  return standsFrom(lo, hi);
}

double extentAlong(const Superquadric& sq, const Eigen::Vector3d& u) {
  const Eigen::Vector3d v = sq.rotation().transpose() * u;
  return std::exp(logExtentCanonical(v.x(), v.y(), v.z(), sq.a[0], sq.a[1], sq.a[2], sq.e1, sq.e2));
}

FitBounds fitBoundsFor(const Points3d& segment, int segment_id, const FitBoundsSource& source,
                       const SuperquadricParams& params) {
  FitBounds bounds;
  if (!params.bounded_fit || segment.empty()) return bounds;
  bounds.params = params;
  bounds.margin_m = source.margin_m;
  if (source.view && !source.view->empty()) bounds.view = source.view;
  if (source.noise && source.noise->estimated && source.sweep) {
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (const auto& p : segment) centroid += p;
    centroid /= static_cast<double>(segment.size());
    const Eigen::Vector3d origin = source.sweep->sensor_origin_.head<3>().cast<double>();
    bounds.noise_m = source.noise->sigmaAt((centroid - origin).norm());
  }
  if (source.has_floor && source.floor.head<3>().allFinite() &&
      std::abs(source.floor.head<3>().norm() - 1.0) < 1e-6) {
    bounds.has_floor = true;
    bounds.up = source.floor.head<3>();
    bounds.floor_offset = source.floor[3];
    bounds.floor_band_m = source.floor_band_m;
  }

  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const auto& p : segment) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  if (!lo.allFinite() || !hi.allFinite()) return bounds;
  const double reach = kInflate * (hi - lo).maxCoeff() + source.margin_m;
  lo.array() -= reach;
  hi.array() += reach;
  const double spacing = medianSpacing(segment);
  // Sweep points nearer than this to the segment may be its own (missed by segmentation).
  const double own = std::max(source.margin_m, 2.0 * spacing);
  Points3d outside, floor_points, others;

  // Space the sweep saw through, sampled on a grid over the box.
  if (source.view && !source.view->empty()) {
    const Eigen::Vector3d size = hi - lo;
    const double step =
        std::max(std::cbrt(size.prod() / kGridCells), std::max(source.margin_m, 1e-3));
    for (double x = lo.x() + 0.5 * step; x < hi.x(); x += step) {
      for (double y = lo.y() + 0.5 * step; y < hi.y(); y += step) {
        for (double z = lo.z() + 0.5 * step; z < hi.z(); z += step) {
          const Eigen::Vector3d p(x, y, z);
          if (source.view->classify(p.cast<float>(), source.margin_m) == Visibility::kFree)
            outside.push_back(p);
        }
      }
    }
  }
  // Surfaces observed near the segment that are not its own.
  if (source.sweep && source.labels && source.labels->size() == source.sweep->size()) {
    std::unique_ptr<PointGrid> grid;
    if (own > 0.0) grid = std::make_unique<PointGrid>(segment, own);
    const Cloud& sweep = *source.sweep;
    for (std::size_t i = 0; i < sweep.size(); ++i) {
      if ((*source.labels)[i] == segment_id) continue;
      const Eigen::Vector3d p = sweep[i].getVector3fMap().cast<double>();
      if (!p.allFinite() || (p.array() < lo.array()).any() || (p.array() > hi.array()).any())
        continue;
      if (bounds.view && bounds.has_floor &&
          bounds.heightAboveFloor(p) <= bounds.floor_band_m + source.margin_m)
        floor_points.push_back(p);
      else
        others.push_back(p);
      if (grid && grid->nearest(p) >= 0) continue;
      outside.push_back(p);
    }
  }
  bounds.outside = subsample(outside, params.bound_points);
  bounds.rests_on_floor = restsOnFloor(segment, floor_points, others, spacing, bounds,
                                       &bounds.lowest_height_m, &bounds.support);
  bounds.hidden_beneath = bounds.support == FloorSupport::kHidden;
  if (bounds.comesDownToFloor(segment)) bounds.support = FloorSupport::kPoints;
  return bounds;
}

Points3d mirroredHiddenSide(const Points3d& points, const FitBounds& bounds, double roundness,
                            bool standing_part, bool round_section) {
  if (!bounds.view || bounds.params.mirror_max_free <= 0.0 || points.size() < 11 ||
      !(standing_part ? bounds.has_floor : bounds.standsOnFloor(points)))
    return {};
  // Horizontal view direction v and lateral direction u.
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : points) centroid += p;
  centroid /= static_cast<double>(points.size());
  const Eigen::Vector3d viewpoint = bounds.view->origin().cast<double>();
  Eigen::Vector3d v = centroid - viewpoint;
  v -= v.dot(bounds.up) * bounds.up;
  if (v.norm() < 1e-9) return {};
  v.normalize();
  const Eigen::Vector3d u = bounds.up.cross(v);
  // The silhouette's two ends: the points within the outer 2 % of the lateral range on
  // each side; the middle of their median positions is the centre of a centrally
  // symmetric object (medians: the range noise of grazing rays scatters them in depth).
  double u_lo = std::numeric_limits<double>::infinity(), u_hi = -u_lo;
  for (const auto& p : points) {
    u_lo = std::min(u_lo, u.dot(p));
    u_hi = std::max(u_hi, u.dot(p));
  }
  const double band = kEndBand * (u_hi - u_lo);
  std::vector<double> left_depth, right_depth;
  Eigen::Vector3d centre = 0.5 * (u_lo + u_hi) * u;
  for (const auto& p : points) {
    const double lateral = u.dot(p);
    if (lateral <= u_lo + band) left_depth.push_back(v.dot(p));
    if (lateral >= u_hi - band) right_depth.push_back(v.dot(p));
  }
  const auto median = [](std::vector<double>& x) {
    std::nth_element(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(x.size() / 2), x.end());
    return x[x.size() / 2];
  };
  centre += 0.5 * (median(left_depth) + median(right_depth)) * v;
  // A round section's centre from its curvature, where it lies plausibly behind the middle
  // (a flat view has no curvature to go by: a leaf maps onto itself).
  round_section = round_section && !bounds.isFlat(points, kFlatRatio);
  Eigen::Vector3d circles;
  const double width = u_hi - u_lo;
  if (round_section && sectionCirclesCentre(points, bounds.up, centre, &circles) &&
      v.dot(circles) > v.dot(centre) && v.dot(circles) - v.dot(centre) <= kMaxCentreDepth * width) {
    centre = circles;
  } else if (round_section || roundness > 0.0) {
    // A round silhouette's ends are tangent points, in front of the centre by r^2 / D, and
    // the band's median lies in front of them by about r sqrt(2 f - f^2) (f: the band's
    // share of the width); a box's ends are its corners, level with the centre.
    roundness = round_section ? 1.0 : roundness;
    const double r = 0.5 * width;
    Eigen::Vector3d to_centre = centre - viewpoint;
    to_centre -= to_centre.dot(bounds.up) * bounds.up;  // horizontal
    const double distance = std::max(to_centre.norm(), r);
    centre += std::min(1.0, roundness) *
              (r * std::sqrt(2.0 * kEndBand - kEndBand * kEndBand) + r * r / distance) * v;
  }
  // Point reflection about the vertical axis through the centre (height kept).
  Points3d mirrored;
  mirrored.reserve(points.size());
  std::size_t free = 0;
  for (const auto& p : points) {
    Eigen::Vector3d d = p - centre;
    d -= d.dot(bounds.up) * bounds.up;
    const Eigen::Vector3d m = p - 2.0 * d;
    if (bounds.view->classify(m.cast<float>(), bounds.margin_m) == Visibility::kFree) ++free;
    mirrored.push_back(m);
  }
  if (static_cast<double>(free) >
      bounds.params.mirror_max_free * static_cast<double>(mirrored.size()))
    return {};
  return mirrored;
}

namespace {
/// Where the search from `start` along `dir` first meets space the sweep saw through (up to
/// `reach`, in `step`s): the middle of the gap before it, or false.
bool gapMiddle(const RangeImage& view, const Eigen::Vector3d& start, const Eigen::Vector3d& dir,
               double step, double reach, Eigen::Vector3d* middle) {
  // A surface already in free space is the outside points' business, not a gap's.
  if (view.classify(start.cast<float>(), 0.0) == Visibility::kFree) return false;
  for (double h = step; h <= reach; h += step) {
    if (view.classify((start + h * dir).cast<float>(), 0.0) == Visibility::kFree) {
      *middle = start + 0.5 * (h - step) * dir;
      return true;
    }
  }
  return false;
}
}  // namespace

Points3d gapMiddles(const Superquadric& sq, const FitBounds& bounds, const Points3d* points) {
  Points3d out;
  if (!bounds.view || !bounds.has_floor) return out;
  const Eigen::Matrix3d r = sq.rotation();
  const int k = uprightAxis(r, bounds.up);
  if (k < 0) return out;
  const Eigen::Vector3d up = r.col(k).dot(bounds.up) > 0.0 ? r.col(k) : Eigen::Vector3d(-r.col(k));
  const int i = (k + 1) % 3, j = (k + 2) % 3;
  Eigen::Vector3d middle;
  // Up: a 3 x 3 grid of columns over the top face, from the highest return on the object
  // where the top lies above it.
  double top = std::numeric_limits<double>::infinity();
  if (points && !points->empty()) {
    top = -top;
    for (const auto& p : *points) top = std::max(top, up.dot(p));
  }
  const double up_step = std::max(kGapStepM, sq.a[k] / 50.0);
  for (double oi : {-0.5, 0.0, 0.5}) {
    for (double oj : {-0.5, 0.0, 0.5}) {
      Eigen::Vector3d start =
          sq.position + sq.a[k] * up + oi * sq.a[i] * r.col(i) + oj * sq.a[j] * r.col(j);
      const double above = up.dot(start) - top;
      if (above > 0.0) start -= above * up;
      if (gapMiddle(*bounds.view, start, up, up_step, 2.0 * sq.a[k], &middle))
        out.push_back(middle);
    }
  }
  // Across: both ways along each horizontal axis, at three heights.
  for (int m : {i, j}) {
    const double step = std::max(kGapStepM, sq.a[m] / 50.0);
    for (double sign : {1.0, -1.0}) {
      const Eigen::Vector3d dir = sign * r.col(m);
      for (double o : {-0.5, 0.0, 0.5}) {
        Eigen::Vector3d start = sq.position + sq.a[m] * dir + o * sq.a[k] * up;
        if (points) {
          // The farthest return along dir about this height, if the surface lies beyond it.
          double reach = -std::numeric_limits<double>::infinity();
          for (const auto& p : *points)
            if (std::abs(up.dot(p - start)) <= kGapBand * sq.a[k])
              reach = std::max(reach, dir.dot(p - sq.position));
          if (reach > 0.0 && reach < sq.a[m]) start -= (sq.a[m] - reach) * dir;
        }
        if (gapMiddle(*bounds.view, start, dir, step, sq.a[m], &middle)) out.push_back(middle);
      }
    }
  }
  return out;
}

namespace {
/// Standard deviation of `f`'s points across their best plane, less the noise.
double spreadAcross(const PrincipalFrame& f, double noise_m) {
  return std::sqrt(std::max(0.0, f.eigenvalues(0) - noise_m * noise_m));
}
}  // namespace

bool isFlatView(const PrincipalFrame& f, double noise_m, double ratio,
                const Eigen::Vector3d* origin) {
  if (!(spreadAcross(f, noise_m) <= ratio * std::sqrt(f.eigenvalues(1)))) return false;
  if (!origin) return true;
  const Eigen::Vector3d ray = f.centroid - *origin;
  const double range = ray.norm();
  return !(range > 0.0) ||
         std::abs(f.axes.col(0).dot(ray)) > range * std::sin(kScanPlaneDeg * M_PI / 180.0);
}

std::optional<Eigen::Vector3d> FitBounds::sensorOrigin() const {
  if (!view || view->empty()) return std::nullopt;
  return view->origin().cast<double>();
}

bool FitBounds::isFlat(const Points3d& points, double ratio) const {
  const std::optional<Eigen::Vector3d> origin = sensorOrigin();
  return isFlatView(principalFrame(points), noise_m, ratio, origin ? &*origin : nullptr);
}

bool thinToFlatView(const Points3d& points, double noise_m, double min_half_m, Superquadric* sq,
                    const Eigen::Vector3d* origin) {
  if (points.size() < 3 || !sq) return false;
  const PrincipalFrame f = principalFrame(points);
  if (!isFlatView(f, noise_m, kFlatRatio, origin)) return false;
  const double across = spreadAcross(f, noise_m);
  const Eigen::Vector3d normal = f.axes.col(0);
  const Eigen::Vector3d& centroid = f.centroid;
  const Eigen::Matrix3d r = sq->rotation();
  const int k = axisNearest(r, normal);
  if (std::abs(r.col(k).dot(normal)) < std::cos(kThinAxisDeg * M_PI / 180.0)) return false;
  const double half = std::max(std::sqrt(3.0) * across, min_half_m);
  if (!(sq->a(k) > half)) return false;
  sq->a(k) = half;
  sq->position += (centroid - sq->position).dot(normal) * normal;
  return true;
}

double horizontalRoundness(const Superquadric& sq, const Eigen::Vector3d& up) {
  const int k = uprightAxis(sq.rotation(), up);
  if (k < 0) return 0.0;
  // z up: the section is the x-y one, shaped by e2; x or y up: it holds z, shaped by e1.
  const double e = k == 2 ? sq.e2 : sq.e1;
  return std::min(1.0, std::max(0.0, (e - kCornerExponent) / (1.0 - kCornerExponent)));
}

int axisNearest(const Eigen::Matrix3d& r, const Eigen::Vector3d& up) {
  int k = 0;
  for (int j = 1; j < 3; ++j)
    if (std::abs(r.col(j).dot(up)) > std::abs(r.col(k).dot(up))) k = j;
  return k;
}

int uprightAxis(const Eigen::Matrix3d& r, const Eigen::Vector3d& up) {
  const int k = axisNearest(r, up);
  return std::abs(r.col(k).dot(up)) < kUprightCos ? -1 : k;
}

int outsideViolations(const Superquadric& sq, const FitBounds& bounds, double tolerance_m) {
  int n = 0;
  for (const auto& p : bounds.outside)
    if (insideOutside(sq, p) < 1.0 && radialDistance(sq, p) > tolerance_m) ++n;
  return n;
}

}  // namespace novelty_detection
