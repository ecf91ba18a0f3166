#include "shape/least_squares.h"

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "novelty_detection/shape/superquadric_cost.h"
#include "shape/superquadric_kernel.h"

namespace novelty_detection {
namespace detail {
namespace {

constexpr int kN = kFitParameters;
constexpr int kBlocks = 4;
// Ceres' defaults for Levenberg-Marquardt.
constexpr double kInitialRadius = 1e4;
constexpr double kMaxRadius = 1e16;
constexpr double kMinRadius = 1e-32;
constexpr double kMinDiagonal = 1e-6;
constexpr double kMaxDiagonal = 1e32;
constexpr double kMinRelativeDecrease = 1e-3;
constexpr double kSufficientDecrease = 1e-4;
constexpr int kLineSearchTrials = 20;
constexpr double kMinLineSearchStep = 1e-9;

using Jacobian = Eigen::Matrix<double, Eigen::Dynamic, kN>;
using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// A point of the line search: step size, cost and its derivative along the step.
struct LineSample {
  double x = 0.0, value = 0.0, slope = 0.0;
  bool valid = false;
};

/// The minimiser over [lo, hi] of the polynomial through the samples' values and slopes
/// (Hermite interpolation: a cubic through two samples, a quintic through three), as Ceres'
/// line search chooses its next step; half the current step when the current sample failed.
double interpolatedStep(const LineSample& start, const LineSample& previous,
                        const LineSample& current, double lo, double hi) {
  if (!current.valid) return std::min(std::max(0.5 * current.x, lo), hi);
  std::vector<LineSample> samples = {start, current};
  if (previous.valid) samples.push_back(previous);
  const int n = 2 * static_cast<int>(samples.size());  // constraints: degree n - 1
  Eigen::MatrixXd lhs = Eigen::MatrixXd::Zero(n, n);
  Eigen::VectorXd rhs(n);
  for (std::size_t k = 0; k < samples.size(); ++k) {
    const double t = samples[k].x;
    for (int j = 0; j < n; ++j) {
      lhs(2 * k, j) = std::pow(t, n - 1 - j);
      lhs(2 * k + 1, j) = j < n - 1 ? (n - 1 - j) * std::pow(t, n - 2 - j) : 0.0;
    }
    rhs[2 * k] = samples[k].value;
    rhs[2 * k + 1] = samples[k].slope;
  }
  const Eigen::VectorXd c = lhs.fullPivLu().solve(rhs);  // highest power first
  auto value = [&](double t) {
    double v = 0.0;
    for (int j = 0; j < n; ++j) v = v * t + c[j];
    return v;
  };
  double best = 0.5 * (lo + hi), best_value = value(best);
  if (value(lo) < best_value) best = lo, best_value = value(lo);
  if (value(hi) < best_value) best = hi, best_value = value(hi);
  // Stationary points inside [lo, hi]: the derivative's roots (their real parts).
  Eigen::VectorXd d(n - 1);
  for (int j = 0; j < n - 1; ++j) d[j] = (n - 1 - j) * c[j];
  int lead = 0;
  while (lead < n - 1 && std::abs(d[lead]) <= 1e-300) ++lead;
  const int degree = n - 2 - lead;
  if (c.allFinite() && degree >= 1) {
    Eigen::MatrixXd companion = Eigen::MatrixXd::Zero(degree, degree);
    for (int j = 0; j < degree; ++j) companion(0, j) = -d[lead + 1 + j] / d[lead];
    for (int j = 1; j < degree; ++j) companion(j, j - 1) = 1.0;
    const Eigen::EigenSolver<Eigen::MatrixXd> roots(companion, false);
    for (int j = 0; j < degree; ++j) {
      const double t = roots.eigenvalues()[j].real();  // complex roots: their real part
      if (t < lo || t > hi) continue;
      if (value(t) < best_value) best = t, best_value = value(t);
    }
  }
  return best;
}

/// Residuals (and the Jacobian) of every cost function at one point.
class Evaluation {
 public:
  explicit Evaluation(const std::vector<const ceres::CostFunction*>& costs) : costs_(costs) {
    int rows = 0;
    for (const ceres::CostFunction* c : costs_) rows += c->num_residuals();
    residuals.resize(rows);
    jacobian.resize(rows, kN);
    // Batches of eq. 3 write their columns in place; the others into Ceres' blocks, copied.
    for (const ceres::CostFunction* c : costs_)
      batches_.push_back(dynamic_cast<const SuperquadricBatchResidual*>(c));
    int largest = 0;
    for (std::size_t k = 0; k < costs_.size(); ++k)
      if (!batches_[k]) largest = std::max(largest, costs_[k]->num_residuals());
    for (int b = 0; b < kBlocks; ++b)
      blocks_[b].resize(static_cast<std::size_t>(largest) * kBlockSizes[b]);
  }

  /// Evaluates at x; false when a cost function fails or gives a non-finite value.
  bool run(const FitVector& x, bool with_jacobian) {
    const double* parameters[kBlocks];
    for (int b = 0; b < kBlocks; ++b) parameters[b] = x.data() + kBlockStarts[b];
    double* jacobians[kBlocks];
    for (int b = 0; b < kBlocks; ++b) jacobians[b] = blocks_[b].data();
    int row = 0;
    for (std::size_t k = 0; k < costs_.size(); ++k) {
      const ceres::CostFunction* c = costs_[k];
      const int m = c->num_residuals();
      if (batches_[k]) {
        if (!batches_[k]->EvaluateColumnMajor(parameters, residuals.data() + row,
                                              with_jacobian ? jacobian.data() + row : nullptr,
                                              jacobian.rows()))
          return false;
        row += m;
        continue;
      }
      if (!c->Evaluate(parameters, residuals.data() + row, with_jacobian ? jacobians : nullptr))
        return false;
      if (with_jacobian) {
        for (int b = 0; b < kBlocks; ++b) {
          jacobian.block(row, kBlockStarts[b], m, kBlockSizes[b]) =
              Eigen::Map<const RowMajor>(blocks_[b].data(), m, kBlockSizes[b]);
        }
      }
      row += m;
    }
    // A NaN or an infinity anywhere makes a sum non-finite: one vectorised pass each.
    if (!std::isfinite(residuals.squaredNorm())) return false;
    return !with_jacobian || std::isfinite(jacobian.sum());
  }

  double cost() const { return 0.5 * residuals.squaredNorm(); }

  Eigen::VectorXd residuals;
  Jacobian jacobian;

 private:
  const std::vector<const ceres::CostFunction*>& costs_;
  std::vector<const SuperquadricBatchResidual*> batches_;  ///< per cost, null: not a batch
  std::vector<double> blocks_[kBlocks];
};

}  // namespace

bool solveBounded(const std::vector<const ceres::CostFunction*>& costs, FitVector* x_io,
                  const FitVector& lo, const FitVector& hi,
                  const std::array<bool, kFitParameters>& fixed, const LeastSquaresOptions& options,
                  LeastSquaresSummary* summary) {
  using Vec = Eigen::Matrix<double, kN, 1>;
  using Mat = Eigen::Matrix<double, kN, kN>;
  *summary = LeastSquaresSummary();
  Evaluation first(costs), second(costs);
  Evaluation* at_x = &first;
  Evaluation* at_candidate = &second;
  FitVector& x = *x_io;
  if (!at_x->run(x, true)) return false;
  double x_cost = at_x->cost();
  summary->initial_cost = summary->final_cost = x_cost;
  Vec free = Vec::Ones();
  for (int i = 0; i < kN; ++i) free[i] = fixed[i] ? 0.0 : 1.0;
  // Jacobi scaling from the first Jacobian, as Ceres does.
  const Vec scale =
      (Vec::Ones() + at_x->jacobian.colwise().norm().transpose()).cwiseInverse().cwiseProduct(free);
  double radius = kInitialRadius, decrease_factor = 2.0;
  Mat jtj;
  Vec gradient;
  auto normal_equations = [&] {
    normalEquations(at_x->jacobian.data(), at_x->residuals.data(), at_x->jacobian.rows(), kN,
                    jtj.data(), gradient.data());
  };
  normal_equations();
  auto projected_gradient_norm = [&] {
    double norm = 0.0;
    for (int i = 0; i < kN; ++i) {
      if (fixed[i]) continue;
      const double moved = std::min(std::max(x[i] - gradient[i], lo[i]), hi[i]) - x[i];
      norm = std::max(norm, std::abs(moved));
    }
    return norm;
  };
  if (projected_gradient_norm() <= options.gradient_tolerance) return true;
  auto project = [&](const Vec& step, double alpha) {
    FitVector out;
    for (int i = 0; i < kN; ++i) out[i] = std::min(std::max(x[i] + alpha * step[i], lo[i]), hi[i]);
    return out;
  };
  while (summary->iterations < options.max_iterations) {
    ++summary->iterations;
    // The damped system in scaled variables: (S J^T J S + D / radius) dz = -S g, dx = S dz.
    Mat h = scale.asDiagonal() * jtj * scale.asDiagonal();
    Vec rhs = -scale.cwiseProduct(gradient);
    for (int i = 0; i < kN; ++i) {
      if (fixed[i]) {
        h.row(i).setZero();
        h.col(i).setZero();
        h(i, i) = 1.0;
        rhs[i] = 0.0;
      } else {
        h(i, i) += std::min(std::max(h(i, i), kMinDiagonal), kMaxDiagonal) / radius;
      }
    }
    const Eigen::LLT<Mat> llt(h);
    const Vec step = scale.cwiseProduct(llt.solve(rhs));
    if (llt.info() != Eigen::Success || !step.allFinite()) {
      radius /= decrease_factor;
      decrease_factor *= 2.0;
      if (radius < kMinRadius) break;
      continue;
    }
    // The linear model's decrease for the full step; a step it does not decrease is
    // invalid (round-off) and counts as a rejected one.
    const double model_change = -(gradient.dot(step) + 0.5 * step.dot(jtj * step));
    if (!(model_change > 0.0)) {
      radius /= decrease_factor;
      decrease_factor *= 2.0;
      if (radius < kMinRadius) break;
      continue;
    }
    // The step projected onto the box; with a line search, shortened along the projected
    // path until it decreases the cost enough (Armijo).
    double alpha = 1.0;
    FitVector candidate = project(step, alpha);
    // Without the line search the slope is not used, and the Jacobian is only needed where
    // its validity decides (below): half the steps of such fits are rejected.
    auto sample = [&](double at) {
      LineSample out;
      out.x = at;
      if (at_candidate->run(candidate, options.line_search)) {
        out.value = at_candidate->cost();
        if (options.line_search)
          out.slope = (at_candidate->jacobian.transpose() * at_candidate->residuals).dot(step);
        out.valid = true;
      }
      return out;
    };
    LineSample current = sample(alpha);
    bool at_current = current.valid;  // at_candidate holds the current sample's evaluation
    if (options.line_search) {
      const LineSample start{0.0, x_cost, gradient.dot(step), true};
      LineSample previous;
      bool found = true;
      for (int trial = 0;
           !current.valid || current.value > x_cost + kSufficientDecrease * start.slope * current.x;
           ++trial) {
        if (trial + 1 >= kLineSearchTrials) {
          found = false;
          break;
        }
        const double next =
            interpolatedStep(start, previous, current, 1e-3 * current.x, 0.6 * current.x);
        if (next * step.cwiseAbs().maxCoeff() < kMinLineSearchStep) {
          found = false;
          break;
        }
        previous = current;
        alpha = next;
        candidate = project(step, alpha);
        current = sample(alpha);
      }
      if (!found) {  // Ceres keeps the full step
        alpha = 1.0;
        candidate = project(step, alpha);
        current = sample(alpha);
      }
      at_current = current.valid;
    }
    double candidate_cost = at_current ? current.value : std::numeric_limits<double>::infinity();
    bool evaluated = std::isfinite(candidate_cost);
    // Parameter tolerance, on the step taken (after its projection).
    const double x_norm = Eigen::Map<const Vec>(x.data()).norm();
    const double taken =
        (Eigen::Map<const Vec>(candidate.data()) - Eigen::Map<const Vec>(x.data())).norm();
    if (taken <= (x_norm + options.parameter_tolerance) * options.parameter_tolerance) break;
    double cost_change = x_cost - candidate_cost;
    // Function tolerance, on any step (Ceres stops without taking it); a step is taken when
    // its quality rho exceeds the minimum relative decrease.
    auto stops = [&] { return std::abs(cost_change) <= options.function_tolerance * x_cost; };
    auto accepts = [&] { return cost_change / model_change > kMinRelativeDecrease; };
    // A candidate counts as evaluated only with a finite Jacobian too: computed now, without
    // the line search, where that decides (a stop or a step taken).
    if (evaluated && !options.line_search && (stops() || accepts()) &&
        !at_candidate->run(candidate, true)) {
      candidate_cost = std::numeric_limits<double>::infinity();
      evaluated = false;
      cost_change = x_cost - candidate_cost;
    }
    if (evaluated && stops()) break;
    const double rho = cost_change / model_change;
    if (evaluated && accepts()) {
      x = candidate;
      x_cost = candidate_cost;
      std::swap(at_x, at_candidate);
      normal_equations();
      const double t = 2.0 * rho - 1.0;
      radius = std::min(kMaxRadius, radius / std::max(1.0 / 3.0, 1.0 - t * t * t));
      decrease_factor = 2.0;
      summary->final_cost = x_cost;
      if (projected_gradient_norm() <= options.gradient_tolerance) break;
    } else {
      radius /= decrease_factor;
      decrease_factor *= 2.0;
      if (radius < kMinRadius) break;
    }
  }
  return true;
}

}  // namespace detail
}  // namespace novelty_detection
