#include "novelty_detection/shape/superquadric_fit.h"

#include <ceres/ceres.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>

#include "novelty_detection/shape/superquadric.h"
#include "novelty_detection/shape/superquadric_cost.h"
#include "shape/least_squares.h"

namespace novelty_detection {
namespace {

void requirePoints(const Points3d& points, const char* who) {
  if (points.empty()) throw std::invalid_argument(std::string(who) + ": no points to fit");
  for (const auto& p : points) {
    if (!p.allFinite()) {
      throw std::invalid_argument(std::string(who) + ": point set contains a non-finite point");
    }
  }
}

/// The bounds' residuals (fit_bounds.h) in the start model's frame (r0, c0): the hinge on the
/// outside points, weighted so that together they weigh at least as much as the points, and
/// the support when the points stand on the floor, weighing like all of them moved by the
/// same distance (eq. 3's residual changes by about 2 sqrt(a) per metre of offset).
void addBounds(const FitBounds& bounds, const Points3d& points, bool standing,
               const Eigen::Matrix3d& r0, const Eigen::Vector3d& c0, const double* a,
               std::vector<std::unique_ptr<ceres::CostFunction>>* costs) {
  const double n = static_cast<double>(points.size());
  if (!bounds.outside.empty() && bounds.params.outside_weight > 0.0) {
    Points3d q(bounds.outside.size());
    for (std::size_t i = 0; i < q.size(); ++i) q[i] = r0.transpose() * (bounds.outside[i] - c0);
    const double m = static_cast<double>(q.size());
    costs->emplace_back(new SuperquadricOutsideResidual(
        q, bounds.params.outside_weight * std::sqrt(std::max(1.0, n / m))));
  }
  if (bounds.params.support_weight > 0.0 && standing) {
    const double mean_a = (a[0] + a[1] + a[2]) / 3.0;
    const double weight = bounds.params.support_weight * std::sqrt(n) * 2.0 * std::sqrt(mean_a);
    costs->emplace_back(SuperquadricSupportResidual::Create(
        r0.transpose() * bounds.up, bounds.up.dot(c0) + bounds.floor_offset, weight));
  }
}

/// The fit on Ceres (per-point residual blocks, with a robust loss or automatic
/// derivatives): `per_point` under the loss, `costs` without; parameters x in the blocks
/// a, e, w, t within [lo, hi], the fixed rotation components held by a subset manifold.
/// Returns Ceres' iteration count; `cost` receives the final cost.
int solveWithCeres(const std::vector<std::unique_ptr<ceres::CostFunction>>& per_point,
                   const std::vector<std::unique_ptr<ceres::CostFunction>>& costs,
                   const std::string& robust_loss, double loss_scale,
                   const detail::LeastSquaresOptions& ls, const detail::FitVector& lo,
                   const detail::FitVector& hi,
                   const std::array<bool, detail::kFitParameters>& fixed, detail::FitVector* x,
                   double* cost) {
  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  // One loss instance shared by all residuals (the problem owns it once).
  ceres::LossFunction* loss = nullptr;
  if (robust_loss == "huber") {
    loss = new ceres::HuberLoss(loss_scale);
  } else if (robust_loss == "cauchy") {
    loss = new ceres::CauchyLoss(loss_scale);
  }
  double* blocks[4];
  for (int b = 0; b < 4; ++b) blocks[b] = x->data() + detail::kBlockStarts[b];
  for (const auto& c : per_point)
    problem.AddResidualBlock(c.get(), loss, blocks[0], blocks[1], blocks[2], blocks[3]);
  for (const auto& c : costs)
    problem.AddResidualBlock(c.get(), nullptr, blocks[0], blocks[1], blocks[2], blocks[3]);
  std::vector<int> held;
  for (int k = 0; k < 3; ++k)
    if (fixed[5 + k]) held.push_back(k);
  if (!held.empty()) problem.SetManifold(blocks[2], new ceres::SubsetManifold(3, held));
  for (int b = 0; b < 4; ++b) {
    for (int k = 0; k < detail::kBlockSizes[b]; ++k) {
      const int i = detail::kBlockStarts[b] + k;
      if (std::isfinite(lo[i])) problem.SetParameterLowerBound(blocks[b], k, lo[i]);
      if (std::isfinite(hi[i])) problem.SetParameterUpperBound(blocks[b], k, hi[i]);
    }
  }
  ceres::Solver::Options options;
  options.minimizer_type = ceres::TRUST_REGION;
  options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  options.max_num_iterations = ls.max_iterations;
  options.function_tolerance = ls.function_tolerance;
  options.gradient_tolerance = ls.gradient_tolerance;
  options.parameter_tolerance = ls.parameter_tolerance;
  options.num_threads = 1;
  if (!ls.line_search) options.max_num_line_search_step_size_iterations = 0;
  options.minimizer_progress_to_stdout = false;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  *cost = summary.final_cost;
  return static_cast<int>(summary.iterations.size());
}

/// `r` turned so that its axis nearest to `up` lies along it (the other two horizontal);
/// `axis` receives that axis.
Eigen::Matrix3d uprightRotation(const Eigen::Matrix3d& r, const Eigen::Vector3d& up, int* axis) {
  const int k = axisNearest(r, up);
  const int i = (k + 1) % 3, j = (k + 2) % 3;
  Eigen::Matrix3d out;
  out.col(k) = r.col(k).dot(up) < 0.0 ? Eigen::Vector3d(-up) : up;
  Eigen::Vector3d h = r.col(i) - r.col(i).dot(out.col(k)) * out.col(k);
  if (h.norm() < 1e-9) h = out.col(k).unitOrthogonal();
  out.col(i) = h.normalized();
  out.col(j) = out.col(k).cross(out.col(i));
  *axis = k;
  return out;
}

}  // namespace

PrincipalFrame principalFrame(const Points3d& points) {
  requirePoints(points, "principalFrame");
  PrincipalFrame f;
  for (const auto& p : points) f.centroid += p;
  f.centroid /= static_cast<double>(points.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : points) {
    const Eigen::Vector3d d = p - f.centroid;
    cov.noalias() += d * d.transpose();
  }
  cov /= static_cast<double>(points.size());
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  f.eigenvalues = eig.eigenvalues().cwiseMax(0.0);
  f.axes = eig.eigenvectors();
  if (f.axes.determinant() < 0.0) f.axes.col(0) = -f.axes.col(0);
  f.min = Eigen::Vector3d::Constant(std::numeric_limits<double>::max());
  f.max = -f.min;
  for (const auto& p : points) {
    const Eigen::Vector3d q = f.axes.transpose() * (p - f.centroid);
    f.min = f.min.cwiseMin(q);
    f.max = f.max.cwiseMax(q);
  }
  return f;
}

Points3d subsample(const Points3d& points, int max_points, Indices* indices) {
  const std::size_t n = points.size();
  const std::size_t cap = static_cast<std::size_t>(std::max(1, max_points));
  Points3d out;
  if (indices) indices->clear();
  if (n <= cap) {
    out = points;
    if (indices) {
      indices->resize(n);
      for (std::size_t i = 0; i < n; ++i) (*indices)[i] = static_cast<int>(i);
    }
    return out;
  }
  out.reserve(cap);
  // Evenly spread positions i * n / cap: exactly `cap` points, deterministic.
  for (std::size_t k = 0; k < cap; ++k) {
    const std::size_t i = k * n / cap;
    out.push_back(points[i]);
    if (indices) indices->push_back(static_cast<int>(i));
  }
  return out;
}

SuperquadricFitter::SuperquadricFitter(const SuperquadricParams& params) : params_(params) {
  params_.validate();
}

std::vector<Superquadric> SuperquadricFitter::initialGuesses(const Points3d& points) const {
  return initialGuesses(principalFrame(points));
}

std::vector<Superquadric> SuperquadricFitter::initialGuesses(const PrincipalFrame& f) const {
  const double h = std::max(f.halfExtent(), params_.min_size_m);
  const double lo = std::max(params_.min_size_m, params_.min_size_fraction * h);
  std::vector<Superquadric> guesses;
  for (int variant = 0; variant < 2; ++variant) {
    Eigen::Vector3d sizes, centre_local;
    if (variant == 0) {
      sizes = (3.0 * f.eigenvalues).cwiseSqrt();
      centre_local.setZero();
    } else {
      sizes = 0.5 * (f.max - f.min);
      centre_local = 0.5 * (f.max + f.min);
    }
    sizes = sizes.cwiseMax(lo);
    for (int z_axis = 0; z_axis < 3; ++z_axis) {
      // Cyclic permutation of the (right-handed) principal axes: columns x, y, z.
      const int ix = (z_axis + 1) % 3, iy = (z_axis + 2) % 3;
      Eigen::Matrix3d r;
      r.col(0) = f.axes.col(ix);
      r.col(1) = f.axes.col(iy);
      r.col(2) = f.axes.col(z_axis);
      Superquadric sq;
      sq.a = Eigen::Vector3d(sizes[ix], sizes[iy], sizes[z_axis]);
      sq.e1 = sq.e2 = std::min(std::max(1.0, params_.epsilon_min), params_.epsilon_max);
      sq.euler = eulerZyzFromRotation(r);
      sq.position = f.centroid + f.axes * centre_local;
      guesses.push_back(sq);
    }
  }
  return guesses;
}

FitResult SuperquadricFitter::refine(const Points3d& points, const Superquadric& initial,
                                     int max_iterations, bool line_search,
                                     FitMeasures measures) const {
  requirePoints(points, "SuperquadricFitter::refine");
  return solve(points, initial, max_iterations, line_search, measures, nullptr, true);
}

FitResult SuperquadricFitter::solve(const Points3d& points, const Superquadric& initial,
                                    int max_iterations, bool line_search, FitMeasures measures,
                                    const PrincipalFrame* frame, bool bounded) const {
  const PrincipalFrame f = frame ? *frame : principalFrame(points);
  const double h = std::max(f.halfExtent(), params_.min_size_m);
  const double size_lo = std::max(params_.min_size_m, params_.min_size_fraction * h);
  const double size_hi = std::max(params_.max_size_factor * h, 2.0 * size_lo);

  // A standing object within bounds stays upright: one axis along up, turning about it.
  const bool standing = bounded && bounds_ && bounds_->standsOnFloor(points);
  int up_axis = -1;
  const Eigen::Matrix3d r0 = standing && bounds_->params.upright
                                 ? uprightRotation(initial.rotation(), bounds_->up, &up_axis)
                                 : initial.rotation();
  const Eigen::Vector3d c0 = initial.position;
  // The 11 parameters (sizes, exponents, rotation and translation from the start frame),
  // their box, and the rotation components an upright fit holds (only the turn about up is
  // free). The centre may move within size_hi of the point set's centroid (expressed in the
  // start frame), so that a fit cannot run away from its data.
  const Eigen::Vector3d centroid_local = r0.transpose() * (f.centroid - c0);
  const double inf = std::numeric_limits<double>::infinity();
  detail::FitVector x{}, lo, hi;
  std::array<bool, detail::kFitParameters> fixed{};
  for (int k = 0; k < 3; ++k) {
    lo[k] = size_lo, hi[k] = size_hi;
    x[k] = std::min(std::max(initial.a[k], size_lo), size_hi);
    lo[5 + k] = -inf, hi[5 + k] = inf;
    lo[8 + k] = centroid_local[k] - size_hi, hi[8 + k] = centroid_local[k] + size_hi;
    x[8 + k] = std::min(std::max(0.0, lo[8 + k]), hi[8 + k]);
  }
  lo[3] = lo[4] = params_.epsilon_min;
  hi[3] = hi[4] = params_.epsilon_max;
  x[3] = std::min(std::max(initial.e1, params_.epsilon_min), params_.epsilon_max);
  x[4] = std::min(std::max(initial.e2, params_.epsilon_min), params_.epsilon_max);
  if (up_axis >= 0) fixed[5 + (up_axis + 1) % 3] = fixed[5 + (up_axis + 2) % 3] = true;

  // The points in the start model's frame.
  Points3d q(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) q[i] = r0.transpose() * (points[i] - c0);
  // A bounded fit adds each point's first-order surface distance (fit_bounds.h).
  const double surface_weight =
      bounded && bounds_ ? std::max(0.0, bounds_->params.surface_weight) : 0.0;
  const bool robust = params_.robust_loss == "huber" || params_.robust_loss == "cauchy";
  std::vector<std::unique_ptr<ceres::CostFunction>> per_point, costs;
  if (!robust && !params_.autodiff) {
    // One block for all points, with their surface distances: the distances reuse eq. 3's
    // logs and exps.
    costs.emplace_back(new SuperquadricBatchResidual(q, surface_weight));
  } else {
    for (const auto& qi : q) {
      per_point.emplace_back(params_.autodiff ? SuperquadricResidual::Create(qi)
                                              : SuperquadricAnalyticResidual::Create(qi));
    }
    // One block for all points (the robust loss, if any, acts on eq. 3's residuals only).
    if (surface_weight > 0.0)
      costs.emplace_back(new SuperquadricSurfaceResidual(q, surface_weight));
  }
  if (bounded && bounds_) addBounds(*bounds_, points, standing, r0, c0, x.data(), &costs);

  detail::LeastSquaresOptions options;
  options.max_iterations = max_iterations < 0 ? params_.max_iterations : max_iterations;
  options.function_tolerance = params_.function_tolerance;
  // With bounds, each step is searched along its projected path; ranking fits skip the
  // search and take the projected step as it is.
  options.line_search = line_search;
  int solved_iterations = 0;
  double cost = std::numeric_limits<double>::quiet_NaN();
  if (options.max_iterations > 0) {
    if (per_point.empty()) {
      // The small bounded LM (least_squares.h): the same method as Ceres' without its
      // per-problem machinery.
      std::vector<const ceres::CostFunction*> views;
      for (const auto& c : costs) views.push_back(c.get());
      detail::LeastSquaresSummary summary;
      detail::FitVector solved = x;
      if (detail::solveBounded(views, &solved, lo, hi, fixed, options, &summary)) {
        x = solved;
        solved_iterations = summary.iterations + 1;  // counted as Ceres does, with iteration 0
        cost = summary.final_cost;
      }
    } else {
      const double loss_scale = params_.robust_loss_scale * std::sqrt(x[0] * x[1] * x[2]);
      solved_iterations = solveWithCeres(per_point, costs, params_.robust_loss, loss_scale, options,
                                         lo, hi, fixed, &x, &cost);
    }
  }
  const double* a = x.data();
  const double* e = x.data() + 3;
  const double* w = x.data() + 5;
  const double* t = x.data() + 8;

  FitResult result;
  Superquadric& sq = result.sq;
  sq = initial;
  const Eigen::Vector3d wv(w[0], w[1], w[2]);
  const Eigen::Vector3d tv(t[0], t[1], t[2]);
  const double angle = wv.norm();
  const Eigen::Matrix3d dr = angle > 0.0 ? Eigen::AngleAxisd(angle, wv / angle).toRotationMatrix()
                                         : Eigen::Matrix3d::Identity();
  const Eigen::Vector3d av(a[0], a[1], a[2]);
  if (av.allFinite() && std::isfinite(e[0]) && std::isfinite(e[1]) && wv.allFinite() &&
      tv.allFinite()) {
    sq.a = av;
    sq.e1 = e[0];
    sq.e2 = e[1];
    sq.euler = eulerZyzFromRotation(r0 * dr);
    sq.position = c0 + r0 * tv;
  }
  sq.points = static_cast<int>(points.size());
  result.iterations = solved_iterations;
  result.cost = cost;
  if (measures == FitMeasures::kAll || measures == FitMeasures::kRadial) {
    result.mean_radial_distance = meanRadialDistance(sq, points);
  }
  if (measures == FitMeasures::kAll || measures == FitMeasures::kSurface) {
    result.mean_distance = meanSurfaceDistance(sq, points);
  }
  if (measures == FitMeasures::kAll) {
    result.residual = meanSquaredResidual(sq, points);
    sq.residual = result.residual;
  }
  return result;
}

FitResult SuperquadricFitter::fit(const Points3d& points, int max_iterations, bool line_search,
                                  FitMeasures measures) const {
  requirePoints(points, "SuperquadricFitter::fit");
  const PrincipalFrame frame = principalFrame(points);
  const std::vector<Superquadric> guesses = initialGuesses(frame);
  const Points3d screen = subsample(points, params_.screening_points);
  // Every start is screened on the same points: their frame (the fit's bounds) once.
  const PrincipalFrame screen_frame =
      screen.size() == points.size() ? frame : principalFrame(screen);
  FitResult best;
  double best_error = std::numeric_limits<double>::infinity();
  for (const auto& guess : guesses) {
    FitResult r = solve(screen, guess, params_.screening_iterations, line_search,
                        FitMeasures::kRadial, &screen_frame);
    if (r.mean_radial_distance < best_error) {
      best_error = r.mean_radial_distance;
      best = r;
    }
  }
  return solve(points, best.sq, max_iterations, line_search, measures, &frame, true);
}

}  // namespace novelty_detection
