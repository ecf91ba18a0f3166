// The bounded Levenberg-Marquardt solver of the superquadric fits: known minima inside and
// on the bounds, fixed parameters, failure at an unevaluable start, and the same minima as
// Ceres' trust-region LM (the solver it replaces) on one-sided superquadric views.
#include <gtest/gtest.h>

#include <ceres/ceres.h>

#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include "../../src/shape/least_squares.h"
#include "../../src/shape/superquadric_kernel.h"
#include "novelty_detection/shape/superquadric.h"
#include "novelty_detection/shape/superquadric_cost.h"
#include "superquadric_samples.h"

namespace nd = novelty_detection;
using nd::detail::FitVector;
using nd::detail::kFitParameters;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// r_i = s_i (x_i - c_i) + q (x_i - c_i)^3 over the 11 parameters in blocks of 3, 2, 3, 3:
/// separable and monotone in each parameter, so the bounded minimum is each c_i clamped to
/// its box.
class Separable : public ceres::CostFunction {
 public:
  Separable(const FitVector& c, double q, bool fail = false) : c_(c), q_(q), fail_(fail) {
    set_num_residuals(kFitParameters);
    for (int size : nd::detail::kBlockSizes) mutable_parameter_block_sizes()->push_back(size);
  }
  bool Evaluate(double const* const* p, double* r, double** jac) const override {
    if (fail_) return false;
    for (int b = 0; b < 4; ++b) {
      for (int k = 0; k < nd::detail::kBlockSizes[b]; ++k) {
        const int i = nd::detail::kBlockStarts[b] + k;
        const double d = p[b][k] - c_[i];
        const double s = 1.0 + i;
        r[i] = s * d + q_ * d * d * d;
        if (!jac) continue;
        for (int row = 0; row < kFitParameters; ++row)
          jac[b][row * nd::detail::kBlockSizes[b] + k] = row == i ? s + 3.0 * q_ * d * d : 0.0;
      }
    }
    return true;
  }

 private:
  FitVector c_;
  double q_;
  bool fail_;
};

FitVector filled(double v) {
  FitVector x;
  x.fill(v);
  return x;
}

}  // namespace

// The normal equations of a step (J^T J and J^T r from one pass of column dot products) are
// Eigen's products up to rounding, symmetric to the bit, at sizes around the SIMD chunk.
TEST(LeastSquares, NormalEquationsAreTheProducts) {
  std::mt19937 rng(5);
  std::normal_distribution<double> g(0.0, 1.0);
  for (const Eigen::Index rows : {1, 3, 64, 1000, 1537}) {
    Eigen::Matrix<double, Eigen::Dynamic, nd::detail::kFitParameters> j(rows, 11);
    Eigen::VectorXd r(rows);
    for (Eigen::Index i = 0; i < rows; ++i) {
      r[i] = g(rng);
      for (int c = 0; c < 11; ++c) j(i, c) = g(rng) * (1 + c);
    }
    Eigen::Matrix<double, 11, 11> jtj;
    Eigen::Matrix<double, 11, 1> jtr;
    nd::detail::normalEquations(j.data(), r.data(), rows, 11, jtj.data(), jtr.data());
    const Eigen::Matrix<double, 11, 11> expected = j.transpose() * j;
    const Eigen::Matrix<double, 11, 1> expected_r = j.transpose() * r;
    EXPECT_LT((jtj - expected).cwiseAbs().maxCoeff(), 1e-12 * expected.cwiseAbs().maxCoeff())
        << rows << " rows";
    EXPECT_LT((jtr - expected_r).cwiseAbs().maxCoeff(),
              1e-12 * (1 + expected_r.cwiseAbs().maxCoeff()))
        << rows << " rows";
    EXPECT_TRUE(jtj == jtj.transpose()) << rows << " rows";
  }
}

TEST(LeastSquares, SeparableMinimaAreTheTargetsClampedToTheBox) {
  const FitVector lo = filled(-1.0), hi = filled(1.0);
  for (const bool line_search : {true, false}) {
    nd::detail::LeastSquaresOptions options;
    options.line_search = line_search;
    nd::detail::LeastSquaresSummary summary;
    // Targets inside the box: reached.
    FitVector inside;
    for (int i = 0; i < kFitParameters; ++i) inside[i] = 0.9 * std::sin(1.0 + i);
    const Separable to_inside(inside, 0.3);
    FitVector x = filled(0.0);
    ASSERT_TRUE(nd::detail::solveBounded({&to_inside}, &x, lo, hi, {}, options, &summary));
    for (int i = 0; i < kFitParameters; ++i)
      EXPECT_NEAR(x[i], inside[i], 1e-6) << "parameter " << i;
    EXPECT_LT(summary.final_cost, 1e-12);
    // Targets beyond it: those parameters end on their bounds exactly. The others end near
    // their targets: once some parameters press on the bounds, the model promises decreases
    // that the projected steps cannot give, and steps are rejected until the radius is tiny
    // (Ceres' projected LM behaves the same).
    FitVector beyond = inside;
    for (int i = 0; i < kFitParameters; i += 3) beyond[i] = i % 2 ? 2.0 : -2.0;
    const Separable to_beyond(beyond, 0.3);
    x = filled(0.0);
    ASSERT_TRUE(nd::detail::solveBounded({&to_beyond}, &x, lo, hi, {}, options, &summary));
    for (int i = 0; i < kFitParameters; ++i) {
      if (i % 3 == 0) {
        EXPECT_EQ(x[i], i % 2 ? 1.0 : -1.0) << "parameter " << i;
      } else {
        EXPECT_NEAR(x[i], beyond[i], 0.05) << "parameter " << i;
      }
    }
    EXPECT_LT(summary.final_cost, summary.initial_cost);
  }
  // Without bounds every target is reached.
  FitVector far;
  for (int i = 0; i < kFitParameters; ++i) far[i] = 3.0 * std::cos(1.0 + i);
  const Separable to_far(far, 0.3);
  FitVector x = filled(0.0);
  nd::detail::LeastSquaresSummary summary;
  ASSERT_TRUE(
      nd::detail::solveBounded({&to_far}, &x, filled(-kInf), filled(kInf), {}, {}, &summary));
  for (int i = 0; i < kFitParameters; ++i) EXPECT_NEAR(x[i], far[i], 1e-6) << "parameter " << i;
}

TEST(LeastSquares, FixedParametersStayAndAFailedStartChangesNothing) {
  const FitVector c = filled(0.7);
  const Separable cost(c, 0.0);
  std::array<bool, kFitParameters> fixed{};
  fixed[6] = fixed[7] = true;  // two rotation components, as an upright fit holds them
  FitVector x = filled(0.1);
  nd::detail::LeastSquaresSummary summary;
  ASSERT_TRUE(
      nd::detail::solveBounded({&cost}, &x, filled(-kInf), filled(kInf), fixed, {}, &summary));
  for (int i = 0; i < kFitParameters; ++i) {
    if (fixed[i]) {
      EXPECT_EQ(x[i], 0.1) << "parameter " << i;
    } else {
      EXPECT_NEAR(x[i], 0.7, 1e-4) << "parameter " << i;  // to the function tolerance
    }
  }
  const Separable broken(c, 0.0, true);
  FitVector y = filled(0.1);
  EXPECT_FALSE(
      nd::detail::solveBounded({&broken}, &y, filled(-kInf), filled(kInf), {}, {}, &summary));
  EXPECT_EQ(y, filled(0.1));
}

// The solver follows Ceres' LM (scaling, damping, radius updates, projected Armijo line
// search with cubic interpolation): from the same start on the same cost functions it
// reaches the same minimum, with and without the line search.
TEST(LeastSquares, ReachesCeresMinimaOnOneSidedSuperquadricViews) {
  std::mt19937 rng(5);
  const std::vector<nd::Superquadric> shapes = {
      nd::samples::makeSq(Eigen::Vector3d(0.3, 0.2, 0.4), 0.2, 0.2),
      nd::samples::makeSq(Eigen::Vector3d(0.25, 0.25, 0.25), 1.0, 1.0),
      nd::samples::makeSq(Eigen::Vector3d(0.15, 0.15, 0.5), 0.3, 1.0),
      nd::samples::makeSq(Eigen::Vector3d(0.4, 0.3, 0.2), 0.6, 1.4)};
  int compared = 0;
  for (const nd::Superquadric& shape : shapes) {
    nd::Superquadric truth = shape;
    nd::samples::randomPose(truth, rng);
    const Eigen::Vector3d sensor = truth.position + Eigen::Vector3d(3.0, 0.5, 1.0);
    const nd::Points3d pts = nd::samples::noisySamples(truth, 600, 0.01, 31u, &sensor);
    // Points in a start frame at their centroid, start sizes from their spread.
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (const auto& p : pts) centroid += p;
    centroid /= static_cast<double>(pts.size());
    nd::Points3d q;
    for (const auto& p : pts) q.push_back(p - centroid);
    const nd::SuperquadricBatchResidual cost(q, 1.0);
    FitVector lo, hi, start;
    for (int k = 0; k < 3; ++k) {
      start[k] = 0.2, lo[k] = 0.02, hi[k] = 1.5;
      start[5 + k] = 0.0, lo[5 + k] = -kInf, hi[5 + k] = kInf;
      start[8 + k] = 0.0, lo[8 + k] = -1.0, hi[8 + k] = 1.0;
    }
    for (int k = 0; k < 2; ++k) start[3 + k] = 1.0, lo[3 + k] = 0.1, hi[3 + k] = 1.9;
    for (const bool line_search : {true, false}) {
      FitVector ours = start;
      nd::detail::LeastSquaresOptions options;
      options.line_search = line_search;
      options.max_iterations = 100;
      nd::detail::LeastSquaresSummary summary;
      ASSERT_TRUE(nd::detail::solveBounded({&cost}, &ours, lo, hi, {}, options, &summary));

      FitVector theirs = start;
      double* blocks[4];
      for (int b = 0; b < 4; ++b) blocks[b] = theirs.data() + nd::detail::kBlockStarts[b];
      ceres::Problem::Options problem_options;
      problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
      ceres::Problem problem(problem_options);
      problem.AddResidualBlock(const_cast<nd::SuperquadricBatchResidual*>(&cost), nullptr,
                               blocks[0], blocks[1], blocks[2], blocks[3]);
      for (int b : {0, 1, 3}) {  // the rotation is unbounded
        for (int k = 0; k < nd::detail::kBlockSizes[b]; ++k) {
          problem.SetParameterLowerBound(blocks[b], k, lo[nd::detail::kBlockStarts[b] + k]);
          problem.SetParameterUpperBound(blocks[b], k, hi[nd::detail::kBlockStarts[b] + k]);
        }
      }
      ceres::Solver::Options solver_options;
      solver_options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
      solver_options.max_num_iterations = 100;
      solver_options.gradient_tolerance = 1e-10;
      if (!line_search) solver_options.max_num_line_search_step_size_iterations = 0;
      solver_options.logging_type = ceres::SILENT;
      ceres::Solver::Summary ceres_summary;
      ceres::Solve(solver_options, &problem, &ceres_summary);

      EXPECT_NEAR(summary.initial_cost, ceres_summary.initial_cost,
                  1e-9 * ceres_summary.initial_cost);
      EXPECT_NEAR(summary.final_cost, ceres_summary.final_cost, 1e-3 * ceres_summary.final_cost)
          << "line search " << line_search;
      for (int i = 0; i < 3; ++i)
        EXPECT_NEAR(ours[i], theirs[i], 0.01) << "size " << i << ", line search " << line_search;
      ++compared;
    }
  }
  EXPECT_EQ(compared, 8);
}
