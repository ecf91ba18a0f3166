// Turning novel Gaussians into labelled point segments (ChoosePtfromGaussian, Sec. IV-D),
// with a geometric check that scales with the data. ROS-free; PCL stays in the .cpp.
//
// 1. Candidates: points whose posterior mass on the novel Gaussians exceeds
//    posterior_threshold (the GMM-EMD selection decides WHERE the change is).
// 2. Geometric check: a candidate is kept only if its distance to the nearest reference
//    point exceeds tau = max(min_novelty_distance_m, median + f * 1.4826 * MAD) of the
//    nearest-neighbour distances from a sample of current points to the reference. Most of
//    a sweep is unchanged, so the median/MAD measure the noise and sampling mismatch between
//    the two scans; this strips wall/floor points that share a Gaussian with an object.
// 3. Segments: connected components of the kept points, linked when closer than
//    link_factor * (median distance to the 4th nearest kept point, at most the sweep's own
//    median 4th-neighbour spacing at those points, see sweepSpacing); adjacent novel
//    Gaussians touching the same object therefore end up in one segment. Segments smaller than
//    min_segment_points are dropped.
#pragma once

#include <functional>
#include <limits>
#include <memory>
#include <vector>

#include "novelty_detection/params.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

/// Nearest-neighbour distances to a fixed point set (a kd-tree built once).
class NearestNeighbourIndex {
 public:
  NearestNeighbourIndex();
  ~NearestNeighbourIndex();
  NearestNeighbourIndex(NearestNeighbourIndex&&) noexcept;
  NearestNeighbourIndex& operator=(NearestNeighbourIndex&&) noexcept;

  /// Indexes cloud[indices] (all points when indices is empty; non-finite points skipped),
  /// building on up to `threads` threads (the index is the same).
  void build(const Cloud& cloud, const Indices& indices = {}, int threads = 1);
  /// The index of the points at the positions p with keep[p] != 0 (one flag per indexed
  /// point), positions renumbered in build order: equal answers to an index built over those
  /// points, without building one (withinIds() may list them in another order).
  NearestNeighbourIndex restricted(const std::vector<char>& keep) const;
  bool empty() const;
  /// Distance from p to the nearest indexed point (+inf when the index is empty).
  double distance(const Eigen::Vector3f& p) const;
  /// Whether distance(p) <= radius_m, without finding the nearest point (faster when one is
  /// that close).
  bool within(const Eigen::Vector3f& p, double radius_m) const;
  /// Positions in the index (0 .. points - 1, in build order) of the indexed points within
  /// radius_m of p, appended to `out` (unordered).
  void withinIds(const Eigen::Vector3f& p, double radius_m, std::vector<int>* out) const;
  /// The indexed points withinIds() gives for (p, radius_m), summarised: how many, their
  /// centroid and their covariance (mean outer product about the centroid). Summed in
  /// double; after prepareMoments() whole subtrees inside the ball count at once.
  struct Neighbourhood {
    std::size_t count = 0;
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  };
  Neighbourhood neighbourhood(const Eigen::Vector3f& p, double radius_m) const;
  /// Keeps every subtree's sums for neighbourhood() (linear in the points, once).
  void prepareMoments();
  /// The indexed point with position `id` in the index.
  Eigen::Vector3f point(int id) const;
  /// Number of indexed points.
  std::size_t size() const;
  /// Distance from p to its k-th nearest indexed point (p itself counts when indexed);
  /// +inf with fewer than k points.
  double kthDistance(const Eigen::Vector3f& p, int k) const;
  /// For every indexed point (in build order), the mean distance to its k nearest other
  /// indexed points (k clamped to size - 1; 0 for a single point), on up to `threads`
  /// threads; the result does not depend on it. With `kth`, each one's k-th distance too.
  std::vector<double> meanNeighbourDistances(int k, int threads = 1,
                                             std::vector<double>* kth = nullptr) const;
  /// The same for the indexed point `id` alone (equal to its entry above).
  double meanNeighbourDistance(int id, int k, double* kth = nullptr) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// tau = max(floor_m, median + factor * 1.4826 * MAD) of the distances that match: the
/// median and MAD are taken over the distances up to tau itself (the fixed point reached from
/// the closer half), so tau stays the noise scale of the unchanged part however much of the
/// scene changed (floor_m for an empty list).
double noveltyDistanceThreshold(std::vector<double> distances, double factor, double floor_m);

/// Connected components of cloud[indices] with the link rule above. Returns components of at
/// least `min_points` points, as input-cloud indices, largest first; `link_radius_m` gets the
/// radius used.
/// `max_spacing_m` caps the spacing (see sweepSpacing).
std::vector<Indices> linkComponents(const Cloud& cloud, const Indices& indices, double link_factor,
                                    int min_points, double* link_radius_m = nullptr,
                                    double max_spacing_m = std::numeric_limits<double>::infinity());

/// The sweep's own sampling where `points` lie: the median distance from each of `points`
/// (a sample) to its 4th nearest point of cloud[sweep] (`points` a subset of `sweep`); infinity
/// with too few points. Novel points scattered over a far, sparsely sampled wall lie much
/// farther apart than the sweep samples there; their mutual spacing would link (and merge)
/// across metres, so the link radius takes the smaller of the two.
double sweepSpacing(const Cloud& cloud, const Indices& sweep, const Indices& points);
/// As above with an index over cloud[sweep] already built; the sample is every
/// (size / max_samples)-th point of `points`.
double sweepSpacing(const Cloud& cloud, const NearestNeighbourIndex& sweep, const Indices& points,
                    std::size_t max_samples = 2000);

/// The sweep the novel points were found in: its kept points (cloud indices) and, when known,
/// its sensor origin (in the cloud's frame).
struct SweepContext {
  const Indices* kept = nullptr;
  /// An index over cloud[*kept] (same order) shared with completeObjects; built here when null.
  const NearestNeighbourIndex* kept_index = nullptr;
  bool origin_known = false;
  Eigen::Vector3f origin = Eigen::Vector3f::Zero();
};

/// Returns of cloud[kept] that are not in `novel_mask` (one flag per cloud point) and whose
/// beam from `origin` ends in or passes through the box [lo, hi]; counting stops at `enough`.
std::size_t beamsThroughBox(const Cloud& cloud, const Indices& kept,
                            const std::vector<char>& novel_mask, const Eigen::Vector3f& origin,
                            const Eigen::Vector3f& lo, const Eigen::Vector3f& hi,
                            std::size_t enough);

/// Finite returns of the whole cloud (ground included) that are not in `novel_mask` and whose
/// beam from `origin` passes through the box [lo, hi] and ends beyond it: the sweep saw past
/// the box. Returns ending inside the box do not count. Counting stops at `enough`.
std::size_t beamsPastBox(const Cloud& cloud, const std::vector<char>& novel_mask,
                         const Eigen::Vector3f& origin, const Eigen::Vector3f& lo,
                         const Eigen::Vector3f& hi, std::size_t enough);

/// Returns of the whole cloud (ground included) not in `skip` (one flag per cloud point) whose
/// beam from `origin`, continued, meets the box [lo, hi] beyond them: something the sweep saw
/// in front of the box hid that part of it. Counting stops at `enough`.
std::size_t beamsBeforeBox(const Cloud& cloud, const std::vector<char>& skip,
                           const Eigen::Vector3f& origin, const Eigen::Vector3f& lo,
                           const Eigen::Vector3f& hi, std::size_t enough);

/// Segments of novel points (`points` ascending, `owner[k]` the most probable novel Gaussian
/// of points[k], in [0, num_gaussians)): connected pieces (linkComponents with
/// params.link_factor, the spacing capped by sweepSpacing over sweep.kept when given); pieces
/// whose points mostly belong to the same novel Gaussian and whose bounding boxes lie within
/// merge_gap_factor link radii (and their footprints on the floor within
/// merge_floor_gap_factor) are one object seen through the gaps between tilt lines and merge
/// (union-find); two objects side by side that share a Gaussian stay apart when their
/// footprints are farther apart, or, with the sweep's origin known and each piece of at least
/// min_segment_points, when kSeenGapBeams or more of the sweep's beams passed between them to
/// something beyond (beamsPastBox), or when the groups they belong to (each of at least
/// min_segment_points) were seen one in front of the other: kSeenGapBeams or more depth
/// jumps of more than merge_floor_gap_factor link radii (depthJumps) with the farther point
/// below the nearer group's top less a link radius, and their footprints on the floor plan
/// more than kInFrontApartLinks link radii apart. With the origin known, pieces of different
/// Gaussians side by side (footprints within merge_floor_gap_factor link radii) whose gap the
/// sweep did not see merge as pieces of one Gaussian do: no beam passed through or past the
/// gap, and kSeenGapBeams or more ended in front of it (beamsBeforeBox, the pieces' own points
/// aside): one object on both sides of the shadow of another standing before it, two faces of
/// a crate with a person between it and the sensor (after the other side-by-side merges, and
/// only groups of min_segment_points or more each). Side-by-side merges come after the stacked
/// ones, nearest first. Pieces of any Gaussians stacked one above the other (footprints
/// overlapping, vertical gap within merge_gap_factor link radii) merge too: one object cut by a gap
/// between tilt lines; but when the sweep's origin is known and kSeenGapBeams or more of its beams
/// (not novel ones) end in or pass through the gap between them, the sweep saw that gap: two things
/// one above the other (a person below a stray difference on the wall), not merged. With the origin
/// known, pieces one above the other (footprints within merge_floor_gap_factor link radii) farther
/// apart than merge_gap_factor link radii merge too when, seen from the origin, one lies wholly
/// above the other by at most kLineGapSteps of the sweep's steps between scan lines at that
/// bearing (ScanLineSpacing) and the sweep did not see through the gap: at low range noise
/// the link radius is the spacing along a line, a tenth of the gap between lines, and a small
/// far object would come apart line by line. Segments under min_segment_points are dropped;
/// largest first. `link_radius_m` gets the link radius.
constexpr std::size_t kSeenGapBeams = 3;
/// The widest gap between stacked pieces that is one gap between scan lines, in line steps:
/// one step, with room for the step's change across a bearing bin and an object's surface
/// sloping away from the sensor; a line missing between them (two steps) is not bridged.
constexpr double kLineGapSteps = 1.5;
/// Two groups seen one in front of the other are two objects only when no point of one
/// stands within this many link radii of the other's on the floor plan: a box's side seen
/// past its corner, or an arm past a trunk, stands within about one (1.45 at most over the
/// suites' scenes at both noise levels), two objects side by side 30-40 cm apart at 2-3.
constexpr double kInFrontApartLinks = 1.75;
std::vector<Indices> segmentNovelPoints(const Cloud& cloud, const Indices& points,
                                        const std::vector<int>& owner, int num_gaussians,
                                        const SegmentationParams& params,
                                        double* link_radius_m = nullptr,
                                        const SweepContext& sweep = {});

/// Gives each repeated point (pre-processing set it aside, see PreprocessResult) the label of
/// its first occurrence, and adds it to that segment's indices (kept ascending).
void labelDuplicates(const Indices& duplicates, const Indices& duplicate_of,
                     std::vector<int>& labels, std::vector<Segment>& segments);

}  // namespace novelty_detection
