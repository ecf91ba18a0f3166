// A small bounded Levenberg-Marquardt solver for the superquadric fits, internal to the shape
// stage. Ceres' general machinery (a program per problem, a check of every residual and
// Jacobian entry, a copy of the Jacobian into its own matrix, a gradient evaluation at every
// line-search trial and a separate cost evaluation of the step) costs about as much as the
// residuals of an 11-parameter fit; this solver evaluates the same Ceres cost functions, once
// per trial point, and nothing else.
//
// The method is Ceres' trust-region Levenberg-Marquardt (Nocedal & Wright 2006, ch. 10;
// Madsen, Nielsen & Tingleff 2004), step for step: Jacobi column scaling fixed at the first
// Jacobian, diag(J^T J) clamped to [1e-6, 1e32] over the radius as damping, the radius
// updated by the step quality rho (x 1 / max(1/3, 1 - (2 rho - 1)^3) on success, halved with
// a doubling factor on failure), rho the cost change over the linear model's change for the
// full step, a step taken when rho > 1e-3, and Ceres' function, parameter and gradient
// tolerances. A step is projected onto the box [lo, hi]; with the line search it is shortened
// along its projected path until the cost decreases enough (Armijo, sufficient decrease 1e-4,
// each trial from the polynomial through the values and slopes seen, within [1e-3, 0.6] of
// the last), as Ceres does for bounded problems.
#pragma once

#include <ceres/cost_function.h>

#include <array>
#include <vector>

namespace novelty_detection {
namespace detail {

/// The 11 parameters of a superquadric fit: a (3), e (2), w (3), t (3), in that order, the
/// parameter blocks of every superquadric cost.
constexpr int kFitParameters = 11;
constexpr int kBlockSizes[4] = {3, 2, 3, 3};
constexpr int kBlockStarts[4] = {0, 3, 5, 8};
using FitVector = std::array<double, kFitParameters>;

struct LeastSquaresOptions {
  int max_iterations = 50;
  double function_tolerance = 1e-6;
  double gradient_tolerance = 1e-10;
  double parameter_tolerance = 1e-8;
  /// Shorten a step along its projected path until it decreases the cost (Ceres' projected
  /// line search for bounded problems); without it the projected step is taken as it is.
  bool line_search = true;
};

struct LeastSquaresSummary {
  int iterations = 0;  ///< steps tried (Ceres' count of iterations, without its iteration 0)
  double initial_cost = 0.0, final_cost = 0.0;  ///< 1/2 sum of squared residuals
};

/// Minimises 1/2 sum ||r_k||^2 over the cost functions `costs`, each taking the parameter
/// blocks (a, e, w, t) of `x` (sizes 3, 2, 3, 3), within lo <= x <= hi; parameters with
/// fixed[i] stay where they are. `x` starts inside the box and ends at the last accepted
/// point. Returns false when the cost cannot be evaluated at the start (x unchanged).
bool solveBounded(const std::vector<const ceres::CostFunction*>& costs, FitVector* x,
                  const FitVector& lo, const FitVector& hi,
                  const std::array<bool, kFitParameters>& fixed, const LeastSquaresOptions& options,
                  LeastSquaresSummary* summary);

}  // namespace detail
}  // namespace novelty_detection
