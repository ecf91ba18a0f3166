// What one sweep observed from its sensor origin: free, occupied and unknown space, as a
// spherical range image (z-buffer). ROS-free; PCL stays in the .cpp.
//
// A sweep's returns are binned by direction (azimuth, elevation) from the sensor origin into
// square cells; a cell keeps the nearest and farthest range of its returns. The cell size is
// cell_factor times the sweep's own mean angular spacing, sqrt(observed solid angle /
// returns), so it follows the sensor (a tilting laser, a Velodyne, a depth camera) without a
// tuned constant. A scanning sensor leaves empty cells between its scan lines: an empty run
// of cells between two returns along the axis of the pattern's gaps, no longer than
// fill_factor times the 90th percentile of such runs, takes the nearer and the farther
// range of the two returns that bound it. So the space between two lines counts as seen,
// while the space outside the field of view, or beyond the last return, stays unknown.
//
// A query point p at range r in a cell whose 3x3 neighbourhood spans ranges [near, far]
// (or, for points already known to lie farther than tau from every map point, its own
// cell's [near, far] widened by slack_factor times that spread):
//   free      r < near - margin   the sensor saw through p (its rays went farther)
//   occluded  r > far + margin    p lies behind what the sensor saw there
//   occupied  otherwise           p lies at a surface the sensor observed
//   unknown   a cell of the 3x3 has no return (out of view, edge of the view, a gap
//             between lines too wide to fill)
// Every query is O(1). Building costs O(points + cells).
//
// A reference made of several sweeps (ReferenceViews) keeps one image per sweep origin
// (ReferenceVisibility): a point is free when some sweep saw through it.
//
// Why range images rather than an OctoMap: the rule needs free/occupied/unknown along the
// rays each reference sweep actually cast; a z-buffer per sweep answers that exactly, at the
// sweep's own angular resolution, in ~1 ms for 30k points, where ray-casting a 30k sweep
// into an octree at a few cm costs hundreds of ms on two cores, and an octree's voxels
// blur the thin free space beside an object that the rule relies on.
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <functional>
#include <limits>
#include <utility>
#include <vector>

#include "novelty_detection/params.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

enum class Visibility : std::uint8_t { kUnknown = 0, kFree, kOccupied, kOccluded };

class RangeImage {
 public:
  struct Config {
    double cell_factor = 1.0;         ///< cell = factor * mean angular spacing
    double fill_factor = 1.5;         ///< fill gaps up to factor * the p90 gap between returns
    std::size_t max_cells = 4000000;  ///< the cell is enlarged to stay below this
    double slack_factor = 0.05;       ///< kOwnCell: widen by this * the 3x3 range spread
  };

  /// Bins cloud[indices] (all points when `indices` is empty; non-finite points and points
  /// at the origin are skipped) seen from `origin`. Fewer than 3 usable points leave the
  /// image empty (every query unknown).
  void build(const Cloud& cloud, const Indices& indices, const Eigen::Vector3f& origin,
             const Config& config);
  bool empty() const { return cells_.empty(); }

  /// kWindow: [near, far] of the 3x3 cells (conservative: the test for disappearances,
  /// which has no other guard). kOwnCell: p's own cell widened by slack_factor times the
  /// 3x3 spread (for points already known to lie farther than tau from every map point).
  enum class Neighbourhood { kWindow, kOwnCell };
  /// Classifies p (see the header comment); `margin_m` >= 0.
  Visibility classify(const Eigen::Vector3f& p, double margin_m,
                      Neighbourhood mode = Neighbourhood::kWindow) const;

  /// Cell of the direction d (from the origin) and its length; false outside the image.
  bool cellOf(const Eigen::Vector3f& d, int* col, int* row, float* range) const;
  const Eigen::Vector3f& origin() const { return origin_; }
  double cellRad() const { return cell_rad_; }
  int fillRows() const { return fill_rows_; }  ///< half height of the fill window [cells]
  int fillCols() const { return fill_cols_; }  ///< half width of the fill window [cells]
  int cols() const { return cols_; }
  int rows() const { return rows_; }

 private:
  struct Cell {
    float near = std::numeric_limits<float>::infinity();  ///< nearest return [m]
    float far = 0.f;  ///< farthest return [m]; near > far: no return (unknown)
  };

  Eigen::Vector3f origin_ = Eigen::Vector3f::Zero();
  double cell_rad_ = 0.0;
  double slack_factor_ = 0.05;
  double el_min_ = 0.0;
  int cols_ = 0, rows_ = 0, fill_rows_ = 0, fill_cols_ = 0;
  std::vector<Cell> cells_;  ///< row-major, after filling
};

/// What a reference of one or more sweeps observed: one RangeImage per sweep origin. A point
/// is kFree when some sweep saw through it; otherwise kOccupied when some sweep's returns
/// end about there; otherwise kOccluded when some sweep saw something in front of it;
/// otherwise kUnknown. With one sweep this is that sweep's image.
class ReferenceVisibility {
 public:
  /// Adds one sweep's image; empty images (too few points) are not kept.
  void add(RangeImage image) {
    if (!image.empty()) images_.push_back(std::move(image));
  }
  bool empty() const { return images_.empty(); }
  std::size_t views() const { return images_.size(); }
  const std::vector<RangeImage>& images() const { return images_; }

  Visibility classify(const Eigen::Vector3f& p, double margin_m,
                      RangeImage::Neighbourhood mode = RangeImage::Neighbourhood::kWindow) const {
    Visibility best = Visibility::kUnknown;
    for (const RangeImage& image : images_) {
      const Visibility v = image.classify(p, margin_m, mode);
      if (v == Visibility::kFree) return v;
      if (v == Visibility::kOccupied ||
          (v == Visibility::kOccluded && best == Visibility::kUnknown))
        best = v;
    }
    return best;
  }

 private:
  std::vector<RangeImage> images_;
};

/// The range image settings of the visibility parameter group.
inline RangeImage::Config rangeImageConfig(const VisibilityParams& p) {
  RangeImage::Config c;
  c.cell_factor = p.cell_factor;
  c.fill_factor = p.fill_factor;
  c.max_cells = static_cast<std::size_t>(p.max_cells);
  c.slack_factor = p.slack_factor;
  return c;
}

/// The fused rule for a candidate of the GMM-EMD selection (a point carried by the novel
/// Gaussians and farther than tau from every map point):
/// - the reference saw its space as free (`v` = kFree, its rays passed through): novel;
/// - the reference never observed it (occluded, out of view) or its rays ended about there
///   (kOccupied: a surface it saw, sampled too sparsely to lie within tau): not novel (a
///   newly visible surface, e.g. a wall revealed behind a moved box), unless
///   `hidden_unexplained` and the map's mixture does not explain it (`explained` false:
///   its density under Gamma is below the map_likelihood_quantile of the map's own points),
///   e.g. a door leaf swung into space the old leaf hid;
/// - without a reference viewpoint (`have_visibility` false): novel unless explained.
/// Segments of the points this calls newly visible may still be novel as a whole (a door
/// leaf swung into space its old position hid): see hidden_segments.h.
inline bool novelCandidate(bool have_visibility, Visibility v, bool explained,
                           bool hidden_unexplained) {
  if (!have_visibility) return !explained;
  return v == Visibility::kFree || (hidden_unexplained && !explained);
}

/// Per point of `current` (input order): 1 when it is newly visible: not novel
/// (labels[i] == 0), farther than the novelty distance from every reference point
/// (`far_from_map(p)` says so: a search may stop at the first map point that close), and in
/// space the reference did not observe (occluded or unknown in `reference`, with margin
/// `margin_m`). All zeros when `reference` is empty. The points are classified on up to
/// `threads` threads (`far_from_map` must be safe to call concurrently); the result does not
/// depend on it.
std::vector<std::uint8_t> newlyVisible(
    const Cloud& current, const std::vector<int>& labels, const ReferenceVisibility& reference,
    double margin_m, const std::function<bool(const Eigen::Vector3f&)>& far_from_map,
    int threads = 1);

}  // namespace novelty_detection
