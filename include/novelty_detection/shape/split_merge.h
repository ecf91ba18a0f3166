// Split-and-merge of one segment into superquadric parts (paper Sec. V-C, extending
// Chevalier, Jaillet and Baskurt 2003). ROS-free.
#pragma once

#include <cmath>
#include <vector>

#include "novelty_detection/params.h"
#include "novelty_detection/shape/superquadric_fit.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

/// One superquadric part: the points it explains and its fit.
struct SuperquadricPart {
  Indices indices;  ///< into the point set given to SplitMerge::run(), ascending
  FitResult fit;    ///< error measure: fit.mean_distance [m]
};

/// Scale: r = neighbour_distance_factor times the median radius of the smallest
/// two-dimensional neighbourhood of >= 12 points (bridges scan lines), and the sensor noise
/// sigma = median RMS distance of those neighbourhoods to their best plane. A fit
/// is "exact" when its mean distance e <= E = max(error_floor_m, noise_factor * sigma);
/// after splitting, E is raised to noise_factor times the median leaf error if larger
/// (the plane RMS underestimates range noise on laser sweeps).
///
/// Residual noise of a part: sigma_P, the nugget of its fit's residuals (signed distances of
/// each point and of its nearest neighbour along the tangent plane differ by noise alone,
/// sigma_P^2 = median of their squared difference / (2 * 0.4549)). Unlike the plane RMS it
/// sees range noise on laser sweeps (each scan line is exactly planar), so noisy cylinders
/// are not split into pieces. It is at least the sweep's own noise at the segment's range
/// (setSensorNoise()): where the noise is several times the point spacing, a point's
/// nearest neighbours are those its noise moved alike, and the nugget comes out low
/// (measured: 1.1 cm on a cylinder 1.1 m from a laser with 3.2 cm range noise, whose fit
/// is within 2.2 cm of its points), which cut dense views of single shapes into many parts.
///
/// Split: a part P (n points, fit error e = mean first-order Euclidean distance,
/// meanSurfaceDistance(), comparable with the noise unlike the radial distance) is cut by the plane
/// through its centroid normal to its main inertia axis (largest covariance eigenvalue)
/// when e > max(E, (1 + merge_tolerance) sqrt(2/pi) sigma_P) (sqrt(2/pi) sigma: the mean
/// distance of pure Gaussian noise; t = merge_tolerance is the slack the merge allows too), both
/// halves keep >= split_min_points, and the halves' points-weighted mean error (n1 e1 + n2 e2) / n
/// < split_gain * e, or regardless of the halves when the part is far from explained, e >
/// split_force_factor * E (a cut across a junction can leave both halves mixed, no better than the
/// parent; the merge regroups what belongs together). Parts are split in order of their distortion
/// n * e, recursively, up to 4 * max_parts leaves (a binary tree).
///
/// Neighbours: sibling leaves, and leaves whose points come closer than r (found with a
/// hash grid, once; the merge reuses this topology instead of recomputing it).
///
/// Merge: the merge cost of neighbours i, j is the mean radial error e_ij of one
/// superquadric fitted to their union; it is kept in a memoized matrix and, after a merge,
/// only the merged part's row/column is recomputed. Greedily, the pair with the lowest
/// e_ij among the acceptable ones is merged. Acceptable (Sec. V-C's rule with the overall
/// distortion in place of the worse part's error; t = merge_tolerance absorbs noise): the
/// merged fit is exact (e_ij <= E), or it keeps the pair's share of the distortion and is
/// not bigger than both parts together:
///   e_ij <= (1 + t) (n_i e_i + n_j e_j) / (n_i + n_j)  and  V_ij <= (1 + t) (V_i + V_j).
/// So two clean parts of different shapes (e_ij >> e_i, e_j) or an enclosing blob of two
/// boxes (V_ij >> V_i + V_j) stay apart, while pieces of one shape merge.
/// When none is acceptable and more than max_parts remain, the lowest-e_ij pair is merged
/// anyway. Then pieces cut out of a junction (fitting badly, merging with neither side)
/// are dissolved when the other parts' surfaces explain their points (mean nearest distance
/// <= max(E, (1 + t) e_j)), and every point finally moves to the nearest part surface (two
/// rounds, each kept only if the summed point distance drops). Fits during split and merge
/// use at most split_fit_points points per part and split_iterations LM iterations; the
/// independent ones (the halves of a split, merge costs, refits) run on setThreads()
/// threads with the same result for any count.
class SplitMerge {
 public:
  /// Throws std::invalid_argument if params do not validate.
  explicit SplitMerge(const SuperquadricParams& params);

  /// Test hook: false recomputes every pairwise merge cost after each merge (the
  /// non-memoized reference the memoized result must equal).
  void setMemoize(bool memoize) { memoize_ = memoize; }

  /// Threads for the independent fits (halves of a split, merge costs, refits); the result
  /// is the same for any count. Default: ComputeParams().resolved().
  void setThreads(int threads) { threads_ = threads < 1 ? 1 : threads; }
  /// The sensor's noise normal to the surface where the points lie (the sweep's noise model,
  /// preprocess/range_noise.h) [m]: a floor of every part's residual noise sigma_P. 0 (the
  /// default; also for a negative or non-finite value): the nugget alone.
  void setSensorNoise(double noise_m) {
    sensor_noise_ = noise_m > 0.0 && std::isfinite(noise_m) ? noise_m : 0.0;
  }

  /// Parts of `points` (one connected object or a few touching ones). `whole` (optional)
  /// is an already fitted model of all points, reused as the root's fit. `bounded_whole`
  /// (optional): a fit of all points within what the sweep observed (fit_bounds.h); when
  /// one_part_tolerance >= 0 and its mean distance (on split_fit_points of them) is within
  /// (1 + one_part_tolerance) exactLevel(), it is the one part returned and nothing is split.
  std::vector<SuperquadricPart> run(const Points3d& points, const FitResult* whole = nullptr,
                                    const FitResult* bounded_whole = nullptr) const;

  /// The mean point-to-surface distance up to which run() would keep `model`, a fit of all of
  /// `points`, whole: max(E, (1 + t) sqrt(2 / pi) sigma_P) with E = max(error_floor_m,
  /// noise_factor x local plane RMS) and sigma_P the nugget of the model's residuals (at least
  /// the sensor noise) [m].
  double exactLevel(const Points3d& points, const Superquadric& model) const;

  /// Counters of the last run() (for tests and benchmarks).
  struct Stats {
    int leaves = 0;      ///< parts after splitting
    int merges = 0;      ///< merges performed
    int merge_fits = 0;  ///< merged fits computed (memoization lowers it)
    int neighbour_pairs = 0;
    int dissolved = 0;              ///< junction pieces dissolved into their neighbours
    double noise_m = 0.0;           ///< sensor noise that E scales with: the plane RMS [m]
    double plane_noise_m = 0.0;     ///< local plane RMS [m]
    double residual_noise_m = 0.0;  ///< nugget of the whole fit's residuals (at least the
                                    ///< sensor noise given) [m]
  };
  const Stats& stats() const { return stats_; }

 private:
  // Phases of run(): scale, noise and split in split_merge.cpp; merge, dissolution and
  // boundary reassignment in split_merge_regroup.cpp.

  /// The mean distance of a fit whose residuals are noise of sigma `noise` alone, up to the
  /// merge tolerance: (1 + t) sqrt(2 / pi) noise.
  double exactForNoise(double noise) const;
  /// The point spacing of a point set (times neighbour_distance_factor), a grid over the
  /// points at that spacing and their local plane RMS (split_merge.cpp).
  struct Scale;
  Scale scaleOf(const Points3d& points) const;
  /// exactLevel() at a scale already measured.
  double exactLevel(const Points3d& points, const Superquadric& model, const Scale& scale) const;
  /// LM iteration cap of the fits inside split and merge (they only rank candidates).
  int innerIterations() const;
  /// Ranking fit of the points at `indices` (subsampled to split_fit_points) from `start`.
  FitResult refitPart(const Points3d& points, const Indices& indices,
                      const Superquadric& start) const;
  /// Fills in the measures the ranking fits skip (mean radial distance, residual).
  void completeMeasures(const Points3d& points, std::vector<SuperquadricPart>& parts) const;
  /// Greedy merge of the leaves `parts` with the memoized cost matrix; `adjacent`: their
  /// topology; `exact`: the error of a fit that explains its points within the noise.
  std::vector<SuperquadricPart> merge(const Points3d& points, std::vector<SuperquadricPart> parts,
                                      std::vector<std::vector<char>> adjacent, double exact) const;
  /// Removes junction pieces whose points the other parts' surfaces explain.
  void dissolve(const Points3d& points, double exact, std::vector<SuperquadricPart>& parts) const;
  /// Moves every point to the nearest part surface while the summed distance drops.
  void reassignBoundaries(const Points3d& points, std::vector<SuperquadricPart>& parts) const;

  SuperquadricParams params_;
  SuperquadricFitter fitter_;
  bool memoize_ = true;
  int threads_ = ComputeParams().resolved();
  double sensor_noise_ = 0.0;
  mutable Stats stats_;
};

}  // namespace novelty_detection
