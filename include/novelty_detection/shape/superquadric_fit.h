// Superquadric recovery from points by Levenberg-Marquardt (Ceres) on the paper's cost
// (Sec. V-B, eq. 3), started from the central moments of the points. ROS-free.
#pragma once

#include <limits>
#include <vector>

#include "novelty_detection/params.h"
#include "novelty_detection/shape/fit_bounds.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

/// Centre of gravity and central moments of a point set.
struct PrincipalFrame {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  /// Columns: eigenvectors of the covariance, ascending eigenvalues, right-handed.
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();
  Eigen::Vector3d eigenvalues = Eigen::Vector3d::Zero();  ///< ascending [m^2]
  Eigen::Vector3d min = Eigen::Vector3d::Zero();  ///< extent along the axes, from the centroid
  Eigen::Vector3d max = Eigen::Vector3d::Zero();
  /// Largest half extent along the axes [m] (the scale that the fit's bounds use).
  double halfExtent() const { return 0.5 * (max - min).maxCoeff(); }
};

/// Throws std::invalid_argument for an empty set or a non-finite point.
PrincipalFrame principalFrame(const Points3d& points);

/// One fit and how good it is.
struct FitResult {
  Superquadric sq;
  double mean_radial_distance = 0.0;  ///< [m] over the fitted points: the quality measure
  double mean_distance = 0.0;         ///< [m] first-order Euclidean (meanSurfaceDistance())
  double residual = 0.0;              ///< mean of eq. 3's squared terms over the points
  int iterations = 0;                 ///< LM iterations of the final run
  /// The objective at the result (1/2 the sum of squared residuals, a bounded fit's terms
  /// included): fits of the same points by the same fitter compare by it; NaN without a solve.
  double cost = std::numeric_limits<double>::quiet_NaN();
};

/// Which quality measures a fit computes over its points (each is a pass of logs and exps
/// over the points; fits whose caller reads only some of them skip the others). Fields not
/// computed stay 0.
enum class FitMeasures {
  kAll,      ///< mean_radial_distance, mean_distance and residual
  kRadial,   ///< mean_radial_distance only
  kSurface,  ///< mean_distance only (the error measure of split and merge)
  kNone,     ///< none: the caller uses the model alone
};

/// Fits one superquadric to a point set.
///
/// Cost (eq. 3): sum_i ( sqrt(a1 a2 a3) (F(x_i)^e1 - 1) )^2, one auto-differentiated Ceres
/// residual per point, LM with a dense QR solver. Parameters: sizes (bounded to
/// [max(min_size_m, min_size_fraction h), max_size_factor h], h = the points' largest half
/// extent along their principal axes, so a one-sided view can neither collapse into a flat
/// disc nor explode), e1, e2 in [epsilon_min, epsilon_max], position (within
/// max_size_factor h of the start) and orientation. The orientation is optimised as a
/// rotation vector about the start's rotation (no gimbal lock while iterating) and reported
/// as Z-Y-Z Euler angles.
class SuperquadricFitter {
 public:
  /// Throws std::invalid_argument if params do not validate.
  explicit SuperquadricFitter(const SuperquadricParams& params);

  /// Multi-start fit: every initialGuesses() candidate is improved for
  /// screening_iterations on at most screening_points points; the one with the lowest mean
  /// radial distance is then refined on all points. Throws std::invalid_argument for an
  /// empty set or non-finite points.
  /// max_iterations < 0: the params' max_iterations for the final refinement.
  /// line_search = false: steps that leave the bounds are projected without Ceres' line
  /// search along them (about twice as fast, slightly less robust; for fits that only rank
  /// candidates, as in split and merge).
  /// `measures`: what the result reports (the choice among the starts always uses the
  /// mean radial distance).
  FitResult fit(const Points3d& points, int max_iterations = -1, bool line_search = true,
                FitMeasures measures = FitMeasures::kAll) const;

  /// LM from `initial` on `points` (max_iterations < 0: the params' max_iterations).
  FitResult refine(const Points3d& points, const Superquadric& initial, int max_iterations = -1,
                   bool line_search = true, FitMeasures measures = FitMeasures::kAll) const;

  /// Initial models (Sec. V-B, e1 = e2 = 1): at the centre of gravity, axes from the
  /// central moments, each principal axis in turn as the superquadric's z axis (e1 acts
  /// along z, so a cylinder needs its axis there), sizes a = sqrt(3 lambda) (exact for a
  /// sphere's surface and a solid box) and, for partial views where moments underestimate,
  /// sizes and centre from the points' min/max along the axes.
  std::vector<Superquadric> initialGuesses(const Points3d& points) const;
  /// initialGuesses() from the points' principalFrame().
  std::vector<Superquadric> initialGuesses(const PrincipalFrame& frame) const;

  const SuperquadricParams& params() const { return params_; }

  /// Bounds (fit_bounds.h) that refine() and the final refinement of fit() add to the
  /// points' cost: each point's first-order surface distance beside its eq. 3 residual
  /// (SuperquadricSurfaceResidual, weight surface_weight), the hinge on outside points and,
  /// when the fitted points stand on the floor, the support. The bounds must outlive the
  /// fits; null: none (the default).
  void setBounds(const FitBounds* bounds) { bounds_ = bounds; }

 private:
  /// refine() without the input check; `frame` (optional): principalFrame(points), when
  /// the caller has it already.
  /// `bounded`: add bounds_ (when set) to the cost.
  FitResult solve(const Points3d& points, const Superquadric& initial, int max_iterations,
                  bool line_search, FitMeasures measures, const PrincipalFrame* frame = nullptr,
                  bool bounded = false) const;

  SuperquadricParams params_;
  const FitBounds* bounds_ = nullptr;
};

/// Every `stride`-th point so that at most max_points remain (deterministic); `indices`
/// (optional) receives the kept positions.
Points3d subsample(const Points3d& points, int max_points, Indices* indices = nullptr);

}  // namespace novelty_detection
