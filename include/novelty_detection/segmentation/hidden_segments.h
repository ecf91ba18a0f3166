// Segment-level rule for novelty candidates the reference could not see (ROS-free).
//
// The point rule of visibility.h (novelCandidate) calls a candidate the reference never
// observed (occluded, out of view) newly visible, not novel: a wall revealed behind a moved
// box. A door leaf swung into space that the old leaf hid is, point by point, the same case.
// Whole segments tell them apart. A segment of such candidates (linked and merged like the
// novelty segments) is novel when all of these hold:
// 1. the reference saw something in front of most of its points (occluded, not out of view
//    or about there: nothing is known of what it never looked at);
// 2. it is a surface patch: it has a plane (normal = least principal axis): its second
//    principal spread is at least kMinPatchWidth * tau and its thickness across the plane
//    (least principal spread) below kMaxLocalFlatness of that and at most tau (noise-sized),
//    and the plane lies farther than tau from the current sensor (a plane through the sensor
//    is one scan line's: range noise moves its points along their rays, inside the scan's
//    plane); when its points as a whole are thicker, on its surface: the points near the
//    plane that most of them fit (kSurfaceTrim and below), at least kMinSurfaceShare of
//    them. A few returns linked to a far leaf across a gap between tilt lines are not part
//    of it; two surfaces at an angle or a blob are no patch. Tests 3 and 4 measure the
//    surface, and a novel segment is its surface;
// 3. it is not a continuation of mapped structure: of the reference points (no ground, not
//    disappeared) within ring_factor * tau of it (of one of its points per voxel of half
//    that radius), at least one exists and fewer than
//    max_coplanar lie on its plane (a revealed wall continues the mapped wall around it; a
//    door leaf at a new angle meets the map only along its hinge). A structure point lies on
//    it within plane_factor * tau, or within parallel_factor * tau where its own surface
//    (the structure still there within kLocalPlaneFactor * tau of it) is a plane parallel
//    to the segment's, normals within kParallelDeg: a sweep registered with a small rotation
//    error sees the mapped wall beside the revealed one, offset by the error times the range,
//    while the wall a leaf's hinge meets crosses the leaf's plane at the leaf's angle. What
//    is left of a surface that moved lies on no plane it crosses: a point whose own surface
//    crosses the segment's plane and runs on (within plane_factor * tau of its plane) into
//    disappeared structure within the ring (the old leaf's part about the hinge, which the
//    new leaf hides) is not on it;
// 4. it stands in space: of the current sweep's rays (points) in the cells of its own
//    range image within outline_factor * tau (at the segment's median range) around the
//    segment's cells, those that end past its plane by more than the visibility margin are
//    at least min_free_edge of those that end past or on it (a door leaf has free edges
//    beyond which the sensor sees farther; a revealed background surface has none). Rays,
//    not cells: a cell on the leaf's edge holds both leaf and background returns.
// Every length scales with tau (the data's noise and sampling distance) and the sweep's
// angular spacing. Without a current sensor origin, test 4 cannot be made: nothing revives.
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <vector>

#include "novelty_detection/params.h"
#include "novelty_detection/segmentation/novelty_segmentation.h"
#include "novelty_detection/types.h"
#include "novelty_detection/visibility/visibility.h"

namespace novelty_detection {

/// The measurements behind the rule, for one segment.
struct HiddenSegmentEvidence {
  int points = 0;
  int surface = 0;                ///< of those, on its surface's plane (test 2)
  int occluded = 0;               ///< points the reference saw something in front of
  double width_m = 0.0;           ///< second principal standard deviation
  double thickness_m = 0.0;       ///< least principal standard deviation (across the plane)
  int ring = 0;                   ///< reference structure points around it (not disappeared)
  int ring_coplanar = 0;          ///< of those, on its plane
  int ring_parallel = 0;          ///< of those, beyond plane_factor * tau: parallel and near
  int past = 0;                   ///< outline rays of the current sweep that reach past its plane
  int on = 0;                     ///< outline rays that end on its plane
  double origin_offset_m = -1.0;  ///< distance of its plane from the current sensor (-1: unknown)
};

/// Test 2's surface, for a segment whose points as a whole lie thicker than tau about their
/// plane: the plane of the kSurfaceTrim share of its points nearest it (refitted
/// kSurfaceRounds times from the plane of all of them); the points within kSurfaceBand * tau
/// of it are the surface, and at least kMinSurfaceShare of the segment's points must be.
/// Tests 2-4 measure the surface, and a novel segment is its surface: a few returns of a far
/// wall linked to a leaf across the gap between two tilt lines (the link radius grows with
/// range) are not part of it.
constexpr double kSurfaceTrim = 0.8;
/// Test 2's plane: the surface's second principal spread at least kMinPatchWidth * tau and its
/// least below kMaxLocalFlatness of the second (flatter across than along), and the plane
/// farther than tau from the current sensor: one scan line's points, which range noise moves
/// along their rays, lie in the scan's plane through the sensor, not in the surface's.
constexpr double kMinPatchWidth = 0.75;
constexpr int kSurfaceRounds = 2;
constexpr double kSurfaceBand = 2.0;
constexpr double kMinSurfaceShare = 0.8;

/// Test 3's local surface of a structure point: the structure within kLocalPlaneFactor * tau,
/// at least kMinLocalPoints points, a plane (least principal spread below kMaxLocalFlatness
/// of the second, the second at least kMinLocalWidth * tau), normal within kParallelDeg of the
/// segment's. Where that structure is no plane, the structure within twice the radius is asked
/// once more (up to the ring's radius): far from a tilting laser the scan lines lie farther
/// apart than 2 tau, and the structure within it is one scan line, whose points (range noise
/// moves them along their rays) lie in the scan's plane, not the surface's; across that
/// plane it spreads by the noise alone (about tau / 2.5).
constexpr double kLocalPlaneFactor = 2.0;
constexpr int kMinLocalPoints = 6;
constexpr double kMaxLocalFlatness = 0.5;
constexpr double kMinLocalWidth = 0.5;
constexpr double kParallelDeg = 20.0;

/// A current point's cell in the current sweep's range image, and its range.
struct RayCell {
  int col = -1, row = -1;
  float range = 0.f;
};

/// Cells of every point of `cloud` in `image` (col = -1 for a point outside it).
std::vector<RayCell> rayCells(const Cloud& cloud, const RangeImage& image);

/// What the rule needs about the scene.
struct HiddenSegmentContext {
  const Cloud* current = nullptr;
  const NearestNeighbourIndex* structure = nullptr;  ///< reference points, no ground
  const std::vector<std::uint8_t>* gone = nullptr;   ///< per structure point: disappeared
  /// The disappeared structure points alone (goneIndex(*structure, *gone)), when the caller
  /// keeps one; made per measurement otherwise.
  const NearestNeighbourIndex* gone_points = nullptr;
  const RangeImage* current_image = nullptr;  ///< the current sweep from its origin
  /// Per point of *current: its cell in current_image and range (col < 0: none). Filled
  /// by novelHiddenSegments; without it test 4 bins the points itself.
  const std::vector<RayCell>* rays = nullptr;
  double tau = 0.0;       ///< novelty distance [m]
  double margin_m = 0.0;  ///< visibility margin [m]
  /// Whether structure point `id` disappeared.
  bool goneAt(int id) const {
    return gone && id >= 0 && static_cast<std::size_t>(id) < gone->size() && (*gone)[id];
  }
};

/// An index over the points of `structure` flagged in `gone` (empty when none is).
NearestNeighbourIndex goneIndex(const NearestNeighbourIndex& structure,
                                const std::vector<std::uint8_t>& gone);

/// Measures `segment` (indices into *ctx.current; vis[k] the reference visibility of
/// segment[k]).
HiddenSegmentEvidence measureHiddenSegment(const HiddenSegmentContext& ctx, const Indices& segment,
                                           const std::vector<Visibility>& vis,
                                           const SegmentationParams& params,
                                           Indices* on_surface = nullptr);

/// The rule of the header comment on measured evidence.
bool hiddenSegmentIsNovel(const HiddenSegmentEvidence& e, double tau,
                          const SegmentationParams& params);

/// The segments of `hidden` (ascending indices into `current` of the candidates the point
/// rule called newly visible; hidden_owner / hidden_vis per entry: most probable novel
/// Gaussian in [0, num_gaussians), reference visibility) that the rule calls novel. They are
/// linked and merged like the novel points (segmentNovelPoints). `structure` indexes the
/// reference's points without ground, `gone` flags its disappeared ones (same order). Needs
/// the current sensor origin (current.sensor_origin_); without it returns nothing.
/// `current_image`: the current sweep's range image from that origin with
/// rangeImageConfig(params.visibility), when the caller has built it (built here otherwise);
/// `gone_points`: goneIndex(structure, gone), likewise.
std::vector<Indices> novelHiddenSegments(const Cloud& current, const Indices& hidden,
                                         const std::vector<int>& hidden_owner,
                                         const std::vector<Visibility>& hidden_vis,
                                         int num_gaussians, const NearestNeighbourIndex& structure,
                                         const std::vector<std::uint8_t>& gone, double tau,
                                         const Params& params,
                                         const RangeImage* current_image = nullptr,
                                         const NearestNeighbourIndex* gone_points = nullptr);

/// Continuations of novel segments into hidden space: a moved object that now reaches into
/// the reference's shadow is one object, not part novel and part newly visible. The
/// candidates of `hidden` (ascending indices into `current`, as above) that are in no
/// segment and are linked to a segment's points (closer than `link_radius_m`, directly or
/// through other such candidates) join that segment (segments in order, each kept
/// ascending), breadth first from the segment's points, and at most `max_growth` times the
/// segment's own points (segmentation/hidden_max_growth). With `revealed` and `params`, a
/// segment's continuation that is a revealed surface (revealedSurface) and does not continue
/// the segment's own surface (continuesSegment) is none: the wall or recess an old door leaf
/// hid, now seen beside the leaf; those candidates join no segment. The part of the leaf the
/// reference could not see continues the leaf's plane and joins it, past the cap too: when
/// the continuation continues the segment's own surface, the further candidates linked to
/// them within hidden_plane_factor * tau of that surface's plane join, except those with
/// reference structure (still there) within kLocalPlaneFactor * tau that lies on the plane
/// (a wall the leaf nearly closes against).
void growIntoHidden(const Cloud& current, std::vector<Indices>* segments, const Indices& hidden,
                    double link_radius_m, double max_growth,
                    const HiddenSegmentContext* revealed = nullptr,
                    const SegmentationParams* params = nullptr);

/// Whether cloud points `points` (indices into *ctx.current) are a surface the reference
/// could not see that continues its mapped structure: a plane patch (test 2 above) with
/// reference structure around it, of which at least hidden_max_coplanar lies on its plane
/// (test 3). Uses ctx.current, structure, gone and tau.
bool revealedSurface(const HiddenSegmentContext& ctx, const Indices& points,
                     const SegmentationParams& params);

/// Whether `points` continue `segment`'s own surface: at least half of them lie within
/// hidden_plane_factor * tau of the plane of the segment's points around them (within
/// hidden_ring_factor * tau of one of them). Indices into *ctx.current; uses ctx.tau.
bool continuesSegment(const HiddenSegmentContext& ctx, const Indices& segment,
                      const Indices& points, const SegmentationParams& params);

}  // namespace novelty_detection
