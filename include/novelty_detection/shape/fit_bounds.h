// What bounds a superquadric besides its own points. A laser sees one side of an object;
// the points say nothing of the side it did not see, and a fit to them alone may reach into
// space the sensor saw through, through the table the object stands on, or stop short of the
// floor. Two observations of the same sweep bound it (ROS-free):
//
//  - Outside points. Space the sweep saw through near the object (range image: a sample is
//    free when the returns around its ray lie farther than it by more than a margin), and
//    surfaces the sweep observed near it that are not the object's own (the floor around it,
//    the table under it, a wall behind it), lie outside the object. A fit pays for every
//    outside point that falls inside it: a hinge residual, zero outside the superquadric and
//    eq. 3's residual inside it (F^e1 < 1), weighted so that the outside points together
//    weigh at least as much as the object's points. Space hidden behind the object's visible
//    surface carries no outside point, so the fit may extend there.
//  - Support. An object whose points come down to the floor (their lowest within the floor's
//    band plus support_fraction of their own height), or whose lowest scan line is the floor
//    at its foot (below), stands on it: the fit's lowest extent
//    along up, the superquadric's support function, is drawn onto the floor plane by one
//    residual that weighs like all the points moved by the same distance; and it stands
//    upright: the fit keeps the axis nearest to up along it and turns only about up (the
//    objects a patrol robot meets, boxes, bins, people, doors, stand upright; a one-sided
//    view otherwise lets a box tilt to follow the noise).
//  - Resting on the floor. A tilting laser's lines lie 20-35 cm apart on an object 5-7 m
//    away, and ground removal takes the returns within the floor's band: the lowest points
//    left of a box standing there may be a line or two above the floor. Such an object rests
//    on the floor when the sweep saw no free space beneath its lowest points (not seen
//    through below it: no table's legs, no gap under a shelf) and, at the foot of most of
//    them, returns on the floor itself (what the lowest line hit next).
//  - Hidden beneath. An object whose lower part is hidden behind another one in front of
//    it, or lies outside what the sensor looked at (the field of view of a tilting laser
//    reaches lower ahead than to the side), has no floor observed at its foot. Objects do
//    not float: when the sweep saw no free space beneath its lowest points, the space there
//    is hidden (behind what the sweep saw, or never looked at) and the sweep returned
//    nothing beneath them (no table top, no shelf it could stand on), it rests on the floor
//    all the same. The fit then reaches down to the floor through the hidden space (which
//    no outside point bounds); superquadrics.json says which support was assumed.
//
// The support function of the superquadric F = ((x/a1)^(2/e2) + (y/a2)^(2/e2))^(e2/e1) +
// (z/a3)^(2/e1) = 1 in a unit direction v of its frame is the dual of its nested norm:
//   h(v) = ((|a1 v1|^q2 + |a2 v2|^q2)^(q1/q2) + |a3 v3|^q1)^(1/q1),
//   q1 = 2 / (2 - e1), q2 = 2 / (2 - e2)   (convex for e1, e2 < 2).
#pragma once

#include <Eigen/Core>

#include <cmath>
#include <optional>
#include <vector>

#include "novelty_detection/params.h"
#include "novelty_detection/shape/superquadric.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

class RangeImage;
struct RangeNoise;
struct PrincipalFrame;  // shape/superquadric_fit.h

struct FitBounds {
  /// Points the object does not contain (see the header comment).
  Points3d outside;
  /// The floor: up . p + floor_offset = 0, up a unit normal. Without one, no support.
  bool has_floor = false;
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  double floor_offset = 0.0;
  /// Points this close to the floor count as on it (ground removal's band) [m].
  double floor_band_m = 0.0;
  /// The settings the bounds use: support_fraction, outside_weight, support_weight,
  /// surface_weight, upright, mirror_max_free.
  SuperquadricParams params;
  /// The sweep seen from its own origin (mirroredHiddenSide(), gapMiddles()); null: unknown.
  const RangeImage* view = nullptr;
  double margin_m = 0.0;  ///< free means seen through by more than this
  /// The sensor's range noise (standard deviation normal to a surface) at the segment's
  /// range [m]; 0: unknown.
  double noise_m = 0.0;

  /// The segment rests on the floor although its lowest points lie above the band (header
  /// comment), and their height above the floor [m]: a point set whose lowest is within
  /// the band or the margin of that height (the segment, or the part that holds its
  /// bottom) stands on the floor.
  bool rests_on_floor = false;
  double lowest_height_m = 0.0;
  /// What holds the segment up (types.h): its points, the floor at its foot, or the floor
  /// taken through the hidden space beneath it; none.
  FloorSupport support = FloorSupport::kNone;
  /// It rests on the floor through hidden space (restsOnFloor() found kHidden), whether or
  /// not its points also come down to the floor: the part that holds its bottom does not.
  bool hidden_beneath = false;

  bool empty() const { return outside.empty() && !has_floor; }
  /// The sweep's origin (the view's), when known: whether a point set is a flat view
  /// (isFlatView()) depends on it.
  std::optional<Eigen::Vector3d> sensorOrigin() const;
  /// Whether `points` are a flat view (isFlatView() with the sweep's noise and origin).
  bool isFlat(const Points3d& points, double ratio) const;
  /// Height of p above the floor [m].
  double heightAboveFloor(const Eigen::Vector3d& p) const { return up.dot(p) + floor_offset; }
  /// The lowest and highest height of `points` above the floor (+inf, -inf when empty).
  void heightRange(const Points3d& points, double* lo, double* hi) const;
  /// Whether `points` come down to the floor themselves: their lowest within floor_band_m +
  /// support_fraction * their extent along up above it (the first clause of standsOnFloor()).
  bool comesDownToFloor(const Points3d& points) const;
  /// comesDownToFloor() and standsOnFloor() of points whose height range heightRange() gave
  /// (a floor assumed): one pass over the points answers both.
  bool comesDownFrom(double lo, double hi) const;
  bool standsFrom(double lo, double hi) const;
  /// Whether `points` stand on the floor: their lowest lies within floor_band_m +
  /// support_fraction * their extent along up above it, or they hold the bottom of a segment
  /// that rests on the floor.
  bool standsOnFloor(const Points3d& points) const;
};

/// log h(v) for a direction v in the superquadric's frame (header comment); finite for any v
/// (guarded logs). Templated for ceres::Jet.
template <class T>
T logExtentCanonical(const T& v1, const T& v2, const T& v3, const T& a1, const T& a2, const T& a3,
                     const T& e1, const T& e2) {
  using std::log;
  const T tiny(kSqTinySquared);
  const T q1 = T(2.0) / (T(2.0) - e1);
  const T q2 = T(2.0) / (T(2.0) - e2);
  const T lx = T(0.5) * q2 * log(a1 * a1 * v1 * v1 + tiny);  // log |a1 v1|^q2
  const T ly = T(0.5) * q2 * log(a2 * a2 * v2 * v2 + tiny);
  const T lz = T(0.5) * q1 * log(a3 * a3 * v3 * v3 + tiny);
  return logSumExp((q1 / q2) * logSumExp(lx, ly), lz) / q1;
}

/// Half extent of `sq` along the unit world direction u: max over its surface of
/// u . (x - position) (the same along -u).
double extentAlong(const Superquadric& sq, const Eigen::Vector3d& u);

/// Where the outside points of a segment come from: the sweep it belongs to, in one frame.
struct FitBoundsSource {
  const Cloud* sweep = nullptr;              ///< the whole sweep
  const std::vector<int>* labels = nullptr;  ///< per sweep point: its segment id, 0 for none
  const RangeImage* view = nullptr;          ///< the sweep from its own origin; null or empty: none
  double margin_m = 0.05;                    ///< free means seen through by more than this (tau)
  bool has_floor = false;
  Eigen::Vector4d floor = Eigen::Vector4d(0, 0, 1, 0);  ///< (up, offset), up a unit normal
  double floor_band_m = 0.0;
  const RangeNoise* noise = nullptr;  ///< the sweep's noise model; null: unknown
};

/// Bounds of segment `segment_id` (its points `segment`) from `source` and the params'
/// free_space_* settings: outside points within an inflated box about the segment (free
/// samples on a grid, and sweep points of other segments or of none that lie farther than
/// the margin and twice the segment's point spacing from its points), evenly thinned to at
/// most bound_points; the floor when the source has one, and whether the segment rests on
/// it (restsOnFloor()). Empty when bounds are disabled.
FitBounds fitBoundsFor(const Points3d& segment, int segment_id, const FitBoundsSource& source,
                       const SuperquadricParams& params);

/// Whether a segment whose lowest points lie above the floor's band rests on the floor
/// (header comment): of its lowest points (within kRestBand of its height, or twice its
/// point spacing, above its lowest; at most kRestColumns of them), at most kMaxSeenBeneath
/// have space the sweep saw through (`bounds.view`, margin `bounds.margin_m`) straight below
/// them, sampled every margin (at least 2 cm) down to the band, and at least kMinFloorAtFoot
/// either have a point of `floor_points` (sweep returns within the band plus the margin of the
/// floor) within the margin or twice the point spacing of them on the floor plan (the floor
/// at the foot), or are hidden beneath: no sample below them is seen through by its own
/// range-image cell, some sample lies behind what the sweep saw there or where it did not
/// look, and no point of `others` (the sweep's other returns above the floor) lies below
/// them within that reach on the floor plan. False without a floor or a view.
/// `lowest_height_m` (optional) receives the height of the segment's lowest point above the
/// floor; `support` (optional) receives which of the two held for most of the columns.
bool restsOnFloor(const Points3d& segment, const Points3d& floor_points, const Points3d& others,
                  double spacing, const FitBounds& bounds, double* lowest_height_m = nullptr,
                  FloorSupport* support = nullptr);
constexpr double kRestBand = 0.1;
constexpr int kRestColumns = 32;
constexpr double kMaxSeenBeneath = 0.25;
constexpr double kMinFloorAtFoot = 0.5;

/// The hidden side of a one-sided view by symmetry (as for grasping under incomplete
/// observation: Bohg et al., ICRA 2011; Quispe et al., ICRA 2015). A superquadric is
/// symmetric about its centre; the two ends of the silhouette across the view (the points of
/// lowest and highest lateral coordinate) are each other's reflection, so their midpoint is
/// the centre's place on the floor plan. `points` reflected about the vertical axis through
/// it (heights kept): a cylinder's or a sphere's visible half gains its hidden half, a box
/// seen across a corner its two hidden faces, a flat leaf maps onto itself. Empty (no
/// mirroring) for points that do not stand on the floor, without a view, or when more
/// than mirror_max_free of the mirrored points lie in space the sweep saw through.
/// `roundness` in [0, 1]: how round the object's horizontal section is (0: cornered, its
/// silhouette's ends are corners level with the centre; 1: round, they are tangent points
/// in front of it), from a first fit's exponent.
/// `standing_part`: the points are one part of an object standing on the floor (a person's
/// trunk or limb, standing_parts.h), mirrored though they do not reach the floor themselves.
/// `round_section`: the section is known to be round (an ellipsoid fitted the points as
/// well as free exponents did): a sparse, noisy view rarely holds the tangent points (the
/// grazing returns at the silhouette are lost), so the centre is that of the circles its
/// sections lie on (sectionCirclesCentre()) when it lies behind the silhouette's middle by
/// at most kMaxCentreDepth of its width; else as for roundness 1. Not for a flat view
/// (isFlatView()).
Points3d mirroredHiddenSide(const Points3d& points, const FitBounds& bounds, double roundness = 0.0,
                            bool standing_part = false, bool round_section = false);
constexpr double kMaxCentreDepth = 0.75;

/// The vertical axis the horizontal sections of `points` are circles about, each band of
/// height its own radius (kSectionBands bands over their height; least squares, Gauss-Newton
/// from `start` with the radii eliminated), as a point on the floor plan (no component
/// along `up`); false when degenerate.
bool sectionCirclesCentre(const Points3d& points, const Eigen::Vector3d& up,
                          const Eigen::Vector3d& start, Eigen::Vector3d* centre);
constexpr int kSectionBands = 6;

/// Where a standing, upright fit's surface most likely lies where the sweep did not see it:
/// the middles of the gaps between the fit's surface and the first space the sweep saw
/// through beyond it. A tilting laser's lines leave vertical gaps of several cm at a few
/// metres, and returns at an object's silhouette are sparse and often lost; the true surface
/// lies anywhere in such a gap, so its middle is the unbiased estimate. Searched (margin 0)
/// upwards from the top at a 3 x 3 grid over the top face, and both ways along each
/// horizontal axis at three heights, each search up to the fit's own size. A side facing the
/// sensor meets free space at once (its middle is on the surface) and a hidden side never
/// (no middle). Empty without a view, a floor or an upright axis.
/// `points`: the returns on the object. A gap begins at the last of them, not at a fit's
/// surface that reached beyond it (a refinement towards the middle would otherwise move out
/// by half a gap each time, tops half a line spacing high at 5-7 m): above the highest
/// return, and across beyond the farthest return along the search direction within
/// kGapBand of the fit's half height of the search's height.
Points3d gapMiddles(const Superquadric& sq, const FitBounds& bounds,
                    const Points3d* points = nullptr);
constexpr double kGapBand = 0.25;

/// A flat view: the object's depth across it was not observed. `points` are flat when their
/// spread across their best plane, less the sensor noise `noise_m`, is at most kFlatRatio of
/// their spread along the plane's shorter direction (standard deviations): a thin object (a
/// door leaf, a board, a panel) or one face of a thicker one seen square on. A fit to them
/// may take any depth behind that face (eq. 3's residual even falls as it grows, and the
/// hidden space does not bound it): the thinnest object the points allow is kept. The axis of
/// `sq` nearest the plane's normal (within kThinAxisDeg) is cut to the points' own half
/// thickness (sqrt(3) of their noise-free standard deviation across the plane: a uniform
/// slab; at least `min_half_m`) and its centre moved onto the plane. Returns whether `sq`
/// was cut (never when it is already that thin or the points are not flat).
bool thinToFlatView(const Points3d& points, double noise_m, double min_half_m, Superquadric* sq,
                    const Eigen::Vector3d* origin = nullptr);
constexpr double kFlatRatio = 0.1;
/// Whether points with principal frame `f` are a flat view, by thinToFlatView()'s rule with
/// `ratio` in place of kFlatRatio. With the sensor's `origin`, points whose plane passes
/// through it (the ray to their centroid within kScanPlaneDeg of the plane) are not: they
/// are one scan line (each line of a scanning laser, each row of a depth camera, lies in a
/// plane through the origin, and range noise moves a return along its ray, within it) or a
/// surface seen edge-on, and show no face whose depth went unobserved. A box 5-7 m away seen
/// by one tilt line is such a plane, and thinning its fit across it flattens the box into a
/// horizontal sheet.
bool isFlatView(const PrincipalFrame& f, double noise_m, double ratio = kFlatRatio,
                const Eigen::Vector3d* origin = nullptr);
constexpr double kScanPlaneDeg = 2.0;
constexpr double kThinAxisDeg = 25.0;

/// How round the horizontal section of an upright `sq` is: 0 for a cornered section
/// (exponent 0.1) to 1 for a round one (exponent 1 or more); 0 when no axis is along `up`.
double horizontalRoundness(const Superquadric& sq, const Eigen::Vector3d& up);

/// The hidden lower part of a segment taken to stand on the floor through hidden space
/// (FitBounds::hidden_beneath; `points`, the segment or the part of it that holds its
/// bottom, not coming down to the floor themselves): its lowest band
/// of points (kRestBand of their height or twice their spacing thick) repeated straight down,
/// one band's thickness at a time, to the floor, and thinned evenly to as many points per
/// height as `points` have (a scanner's lines lie farther apart than its points along
/// them; the seen part keeps its weight): a standing object's section continues below
/// what was seen (as its hidden side mirrors its visible one). Without them eq. 3's volume
/// factor and the points keep the fit short of the floor the support draws it to. Empty
/// otherwise.
Points3d extrudedToFloor(const Points3d& points, const FitBounds& bounds);

/// The column of `r` nearest to `up` (largest |r.col(k) . up|).
int axisNearest(const Eigen::Matrix3d& r, const Eigen::Vector3d& up);
/// axisNearest() when that axis lies within about 8 degrees of up, else -1.
int uprightAxis(const Eigen::Matrix3d& r, const Eigen::Vector3d& up);

/// Outside points of `bounds` inside `sq` by more than `tolerance_m` (radially) [count].
int outsideViolations(const Superquadric& sq, const FitBounds& bounds, double tolerance_m);

}  // namespace novelty_detection
