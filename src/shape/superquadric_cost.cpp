#include "novelty_detection/shape/superquadric_cost.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <utility>

#include "shape/pose_jacobian.h"
#include "shape/superquadric_kernel.h"

namespace novelty_detection {
namespace {

using detail::RotationTerms;
using detail::rotationTerms;

/// Ceres' row-major blocks (null ones skipped), from their first row.
detail::JacobianOut rowMajor(double* const* jacobians) {
  detail::JacobianOut out;
  for (int b = 0; b < 4; ++b) {
    out.block[b] = jacobians[b];
    out.row_stride[b] = detail::kBlockSizes[b];
    out.col_stride[b] = 1;
  }
  return out;
}

/// The 11 parameters' columns of a column-major matrix of height `height`, from `first`
/// (the entry of the first row and parameter).
detail::JacobianOut columnMajor(double* first, Eigen::Index height) {
  detail::JacobianOut out;
  for (int b = 0; b < 4; ++b) {
    out.block[b] = first + detail::kBlockStarts[b] * height;
    out.row_stride[b] = 1;
    out.col_stride[b] = height;
  }
  return out;
}

/// The same layout from `rows` rows further down.
detail::JacobianOut advanced(const detail::JacobianOut& in, Eigen::Index rows) {
  detail::JacobianOut out = in;
  for (int b = 0; b < 4; ++b)
    if (out.block[b]) out.block[b] += rows * out.row_stride[b];
  return out;
}

/// log(e^a + e^b) and the softmax weights e^a / (e^a + e^b), e^b / (e^a + e^b), with one
/// exp and one log.
inline double logSumExpWeights(double a, double b, double* wa, double* wb) {
  const bool a_big = a > b;
  const double u = std::exp(a_big ? b - a : a - b);
  const double s = 1.0 + u;
  *wa = (a_big ? 1.0 : u) / s;
  *wb = (a_big ? u : 1.0) / s;
  return (a_big ? a : b) + std::log(s);
}

/// Residual of one point (start-frame coordinates q) and, when ja is not null, its
/// derivatives: ja[3] (sizes), je[2] (exponents), jw[3] (rotation), jt[3] (translation).
inline double pointResidual(const Eigen::Vector3d& q, const double* a, double e1, double e2,
                            const double* t, const RotationTerms& rt, double* ja, double* je,
                            double* jw, double* jt) {
  const Eigen::Vector3d& w = rt.w;
  // p = Exp(w)^T (q - t) = d - sa (w x d) + sb w x (w x d).
  const Eigen::Vector3d d(q.x() - t[0], q.y() - t[1], q.z() - t[2]);
  const Eigen::Vector3d wxd = w.cross(d);
  const Eigen::Vector3d p = d - rt.sa * wxd + rt.sb * w.cross(wxd);

  // Eq. 2 in log space with guarded (squared, clamped) coordinates; see
  // logInsideOutsideCanonical().
  const double sx = p.x() * p.x() / (a[0] * a[0]), rx = sx + kSqTinySquared;
  const double sy = p.y() * p.y() / (a[1] * a[1]), ry = sy + kSqTinySquared;
  const double sz = p.z() * p.z() / (a[2] * a[2]), rz = sz + kSqTinySquared;
  const double lx = std::log(rx) / e2, ly = std::log(ry) / e2;
  const double lb = std::log(rz) / e1;
  double wxw, wyw, wa, wb;  // softmax weights of the two log-sum-exps
  const double lxy = logSumExpWeights(lx, ly, &wxw, &wyw);
  const double la = e2 / e1 * lxy;
  const double l = logSumExpWeights(la, lb, &wa, &wb);
  const double big_s = std::sqrt(a[0] * a[1] * a[2]);
  const double big_e = std::exp(e1 * l);
  const double residual = big_s * (big_e - 1.0);
  if (!ja && !je && !jw && !jt) return residual;

  const double k = big_s * big_e * e1;  // dr/dL
  // dL/dp: d lx / dx = (2 / e2) (x / a1^2) / rx, weighted through the two log-sum-exps.
  const Eigen::Vector3d grad(wa * wxw * (2.0 / e1) * (p.x() / (a[0] * a[0])) / rx,
                             wa * wyw * (2.0 / e1) * (p.y() / (a[1] * a[1])) / ry,
                             wb * (2.0 / e1) * (p.z() / (a[2] * a[2])) / rz);
  const Eigen::Vector3d dr_dp = k * grad;
  if (ja) {
    const double half = 0.5 * residual;
    ja[0] = half / a[0] - k * wa * wxw * (2.0 / (e1 * a[0])) * sx / rx;
    ja[1] = half / a[1] - k * wa * wyw * (2.0 / (e1 * a[1])) * sy / ry;
    ja[2] = half / a[2] - k * wb * (2.0 / (e1 * a[2])) * sz / rz;
  }
  if (je) {
    je[0] = big_s * big_e * (l - wa * la - wb * lb);
    je[1] = big_s * big_e * wa * (lxy - wxw * lx - wyw * ly);
  }
  detail::poseJacobian(rt, p, dr_dp, jw, jt);
  return residual;
}

}  // namespace

bool SuperquadricAnalyticResidual::Evaluate(double const* const* parameters, double* residuals,
                                            double** jacobians) const {
  const RotationTerms rt = rotationTerms(parameters[2]);
  auto block = [jacobians](int b) { return jacobians ? jacobians[b] : nullptr; };
  residuals[0] = pointResidual(q_, parameters[0], parameters[1][0], parameters[1][1], parameters[3],
                               rt, block(0), block(1), block(2), block(3));
  return true;
}

static_assert(SuperquadricBatchResidual::kChunk == detail::kKernelChunk, "chunk size");

SuperquadricBatchResidual::SuperquadricBatchResidual(const std::vector<Eigen::Vector3d>& q,
                                                     double surface_weight)
    : q_(3, static_cast<Eigen::Index>(q.size())),
      surface_weight_(surface_weight),
      terms_(static_cast<Eigen::Index>(q.size()), static_cast<Eigen::Index>(detail::kTerms)) {
  for (std::size_t i = 0; i < q.size(); ++i) q_.col(static_cast<Eigen::Index>(i)) = q[i];
  set_num_residuals(static_cast<int>(q.size()) * (surface_weight > 0.0 ? 2 : 1));
  *mutable_parameter_block_sizes() = {3, 2, 3, 3};
}

bool SuperquadricBatchResidual::Evaluate(double const* const* parameters, double* residuals,
                                         double** jacobians) const {
  if (!jacobians) return evaluate(parameters, residuals, nullptr);
  // Ceres' Jacobian blocks are row-major: the rows of residual i start at i * size(b).
  const detail::JacobianOut out = rowMajor(jacobians);
  return evaluate(parameters, residuals, &out);
}

bool SuperquadricBatchResidual::EvaluateColumnMajor(double const* const* parameters,
                                                    double* residuals, double* jacobian,
                                                    Eigen::Index height) const {
  if (!jacobian) return evaluate(parameters, residuals, nullptr);
  const detail::JacobianOut out = columnMajor(jacobian, height);
  return evaluate(parameters, residuals, &out);
}

bool SuperquadricBatchResidual::evaluate(double const* const* parameters, double* residuals,
                                         const detail::JacobianOut* out) const {
  // Ceres evaluates the cost at a candidate step and, when it accepts the step, the Jacobian
  // at the same parameters: the terms (the logs and exps, most of the cost) are then reused.
  using detail::kBlockSizes;
  bool same = cached_;
  for (int b = 0, m = 0; b < 4; ++b) {
    for (int k = 0; k < kBlockSizes[b]; ++k, ++m) same = same && parameters[b][k] == last_[m];
  }
  const Eigen::Index n = q_.cols();
  if (!same) {
    for (Eigen::Index begin = 0; begin < n; begin += kChunk) {
      detail::superquadricTerms(parameters, q_.data(), terms_.data(), n, begin,
                                std::min(kChunk, n - begin));
    }
    for (int b = 0, m = 0; b < 4; ++b) {
      for (int k = 0; k < kBlockSizes[b]; ++k, ++m) last_[m] = parameters[b][k];
    }
    cached_ = true;
  }
  Eigen::Map<Eigen::VectorXd>(residuals, n) = terms_.col(detail::kResidual);
  for (Eigen::Index begin = 0; begin < n; begin += kChunk) {
    const Eigen::Index m = std::min(kChunk, n - begin);
    if (out) {
      detail::superquadricJacobian(parameters, terms_.data(), n, begin, m, advanced(*out, begin));
    }
    if (surface_weight_ > 0.0) {
      detail::JacobianOut rows;  // the surface residuals' rows follow eq. 3's n rows
      if (out) rows = advanced(*out, n + begin);
      detail::superquadricSurfaceResiduals(parameters, terms_.data(), n, begin, m, surface_weight_,
                                           residuals + n + begin, out ? &rows : nullptr);
    }
  }
  return true;
}

SuperquadricOutsideResidual::SuperquadricOutsideResidual(const std::vector<Eigen::Vector3d>& q,
                                                         double weight)
    : q_(3, static_cast<Eigen::Index>(q.size())),
      weight_(weight),
      box_q_(3, static_cast<Eigen::Index>(q.size())),
      terms_(static_cast<Eigen::Index>(q.size()), static_cast<Eigen::Index>(detail::kTerms)) {
  for (std::size_t i = 0; i < q.size(); ++i) q_.col(static_cast<Eigen::Index>(i)) = q[i];
  inside_box_.reserve(q.size());
  for (int b = 0; b < 4; ++b) rows_[b].resize(q.size() * detail::kBlockSizes[b]);
  set_num_residuals(static_cast<int>(q.size()));
  *mutable_parameter_block_sizes() = {3, 2, 3, 3};
}

bool SuperquadricOutsideResidual::Evaluate(double const* const* parameters, double* residuals,
                                           double** jacobians) const {
  using detail::kBlockSizes;
  const Eigen::Index n = q_.cols();
  std::fill(residuals, residuals + n, 0.0);
  if (jacobians) {
    for (int b = 0; b < 4; ++b)
      if (jacobians[b]) std::fill(jacobians[b], jacobians[b] + n * kBlockSizes[b], 0.0);
  }
  // The points inside the model's box, p = Exp(w)^T (q - t) as the kernel computes it.
  const RotationTerms rt = rotationTerms(parameters[2]);
  const double* a = parameters[0];
  const double* t = parameters[3];
  inside_box_.clear();
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Vector3d p = detail::canonicalPoint(rt, q_.col(i), t);
    if (std::abs(p.x()) < a[0] && std::abs(p.y()) < a[1] && std::abs(p.z()) < a[2])
      inside_box_.push_back(static_cast<int>(i));
  }
  const Eigen::Index m = static_cast<Eigen::Index>(inside_box_.size());
  if (m == 0) return true;
  // Their coordinates and terms in the first m columns and rows of the scratch (sized for
  // all points: n is its leading dimension).
  for (Eigen::Index j = 0; j < m; ++j) box_q_.col(j) = q_.col(inside_box_[j]);
  detail::JacobianOut out;
  if (jacobians) {
    for (int b = 0; b < 4; ++b) {
      out.block[b] = jacobians[b] ? rows_[b].data() : nullptr;
      out.row_stride[b] = kBlockSizes[b];
      out.col_stride[b] = 1;
    }
  }
  for (Eigen::Index begin = 0; begin < m; begin += detail::kKernelChunk) {
    const Eigen::Index len = std::min(detail::kKernelChunk, m - begin);
    detail::superquadricTerms(parameters, box_q_.data(), terms_.data(), n, begin, len);
    if (jacobians)
      detail::superquadricJacobian(parameters, terms_.data(), n, begin, len, advanced(out, begin));
  }
  for (Eigen::Index j = 0; j < m; ++j) {
    const int i = inside_box_[j];
    const double r = terms_(j, detail::kResidual);
    if (!(r < 0.0)) continue;  // outside the model: zero and flat
    residuals[i] = -weight_ * r;
    if (!jacobians) continue;
    for (int b = 0; b < 4; ++b) {
      if (!jacobians[b]) continue;
      for (int k = 0; k < kBlockSizes[b]; ++k)
        jacobians[b][i * kBlockSizes[b] + k] = -weight_ * rows_[b][j * kBlockSizes[b] + k];
    }
  }
  return true;
}

}  // namespace novelty_detection
