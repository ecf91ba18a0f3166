// Ceres cost functions of the superquadric fit (paper eq. 3), one residual per point.
// Included by the fitter and its tests only (it pulls in Ceres). ROS-free.
//
// Parameterisation shared by both: the point is given in the frame of the start model,
// q = R0^T (p - c0); the parameters move that frame: position c0 + R0 t, rotation
// R0 Exp(w), so the point in the superquadric's canonical frame is p_sq = Exp(w)^T (q - t).
// Parameter blocks: sizes a[3], exponents e[2] = (e1, e2), rotation vector w[3],
// translation t[3]. Residual: sqrt(a1 a2 a3) (F(p_sq)^e1 - 1) (eq. 3), F from eq. 2.
#pragma once

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Core>
#include <vector>

#include "novelty_detection/shape/fit_bounds.h"
#include "novelty_detection/shape/superquadric.h"

namespace novelty_detection {
namespace detail {
struct JacobianOut;  // shape/superquadric_kernel.h
}  // namespace detail

/// Automatic differentiation (reference implementation; guarded powers are in
/// fitResidualCanonical(), which works on Jets).
struct SuperquadricResidual {
  explicit SuperquadricResidual(const Eigen::Vector3d& q) : q_(q) {}

  template <class T>
  bool operator()(const T* const a, const T* const e, const T* const w, const T* const t,
                  T* residual) const {
    const T d[3] = {T(q_.x()) - t[0], T(q_.y()) - t[1], T(q_.z()) - t[2]};
    const T minus_w[3] = {-w[0], -w[1], -w[2]};
    T p[3];
    ceres::AngleAxisRotatePoint(minus_w, d, p);  // Exp(w)^T (q - t)
    residual[0] = fitResidualCanonical(p[0], p[1], p[2], a[0], a[1], a[2], e[0], e[1]);
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector3d& q) {
    return new ceres::AutoDiffCostFunction<SuperquadricResidual, 1, 3, 2, 3, 3>(
        new SuperquadricResidual(q));
  }

  Eigen::Vector3d q_;
};

/// The same residual with analytic derivatives (about 5x faster than the Jets). With
/// L = log F, E = F^e1 = exp(e1 L), S = sqrt(a1 a2 a3), r = S (E - 1):
///   dr/da_k = S (E - 1) / (2 a_k) + S E e1 dL/da_k,   dr/de1 = S E (L - wA A - wB B),
///   dr/de2 = S E wA (Lxy - wx lx - wy ly),            dr/dp = S E e1 grad L,
///   dp/dt = -Exp(w)^T,   dp/dw = [p]x J_r(w)  (J_r: right Jacobian of SO(3)),
/// where lx, ly, lz are the logs of the three terms of eq. 2, Lxy = log(e^lx + e^ly),
/// A = (e2/e1) Lxy, B = lz, L = log(e^A + e^B) and the w's are the softmax weights.
class SuperquadricAnalyticResidual : public ceres::SizedCostFunction<1, 3, 2, 3, 3> {
 public:
  explicit SuperquadricAnalyticResidual(const Eigen::Vector3d& q) : q_(q) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  static ceres::CostFunction* Create(const Eigen::Vector3d& q) {
    return new SuperquadricAnalyticResidual(q);
  }

 private:
  Eigen::Vector3d q_;
};

/// All points' residuals in one cost function (the same values and derivatives as one
/// SuperquadricAnalyticResidual per point, up to rounding): the rotation terms are computed
/// once per evaluation instead of once per point, the logs and exps run vectorised over
/// the points, and Ceres handles one block instead of n. Only valid without a robust loss
/// (a loss would act on the block's summed squares).
/// With a surface weight the block also holds each point's SuperquadricSurfaceResidual
/// (residuals n..2n-1, equal to it up to rounding), computed from the same logs and exps.
class SuperquadricBatchResidual : public ceres::CostFunction {
 public:
  /// `q`: the points in the start model's frame; `surface_weight` > 0 adds their weighted
  /// first-order surface distances.
  explicit SuperquadricBatchResidual(const std::vector<Eigen::Vector3d>& q,
                                     double surface_weight = 0.0);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;
  /// The same residuals, with the Jacobian written into the columns of a column-major matrix
  /// of height `height`: the entry of residual i and parameter j (the blocks' 11 parameters
  /// in order) at jacobian[j * height + i] (null: residuals only). The layout a dense solver
  /// works on, written directly instead of copied from Ceres' row-major blocks.
  bool EvaluateColumnMajor(double const* const* parameters, double* residuals, double* jacobian,
                           Eigen::Index height) const;

  /// Points per chunk of an evaluation (a multiple of the SIMD packet size; the kernels'
  /// chunk, detail/superquadric_kernel.h).
  static constexpr Eigen::Index kChunk = 64;

 private:
  bool evaluate(double const* const* parameters, double* residuals,
                const detail::JacobianOut* out) const;

  Eigen::Matrix3Xd q_;
  double surface_weight_;
  // The terms at the last evaluated parameters (one residual block per problem, so Ceres
  // never evaluates it concurrently).
  mutable Eigen::MatrixXd terms_;  ///< points x the kernels' terms
  mutable double last_[11] = {};
  mutable bool cached_ = false;
};

/// The first-order surface distance of each point, (1 - F^(-e1/2)) / |grad F^(e1/2) / F^(e1/2)|
/// (Taubin's gradient-normalised distance of the level set F^(e1/2) = 1: the distance to
/// the surface to first order, negative inside), times `weight`, with analytic derivatives.
/// Unlike eq. 3 it carries no volume factor: added to eq. 3's residuals it pulls the surface
/// onto the points the volume factor lets a fit cut through.
class SuperquadricSurfaceResidual : public ceres::CostFunction {
 public:
  /// `q`: the points in the start model's frame.
  SuperquadricSurfaceResidual(const std::vector<Eigen::Vector3d>& q, double weight);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  std::vector<Eigen::Vector3d> q_;
  double weight_;
};

/// The hinge on outside points (fit_bounds.h): per point weight * max(0, -r), r eq. 3's
/// residual (negative inside the superquadric), with its derivatives; zero and flat outside.
/// A superquadric lies within its box |x| <= a1, |y| <= a2, |z| <= a3: eq. 3 is evaluated
/// only for the points inside the box at the given parameters (most of a fit's outside
/// points lie beyond it), the others are zero without their logs and exps.
class SuperquadricOutsideResidual : public ceres::CostFunction {
 public:
  /// `q`: the outside points in the start model's frame.
  SuperquadricOutsideResidual(const std::vector<Eigen::Vector3d>& q, double weight);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Eigen::Matrix3Xd q_;
  double weight_;
  // Scratch of an evaluation, kept to avoid allocating at each one.
  mutable std::vector<int> inside_box_;  ///< the points inside the model's box
  mutable Eigen::Matrix3Xd box_q_;       ///< their coordinates
  mutable Eigen::MatrixXd terms_;        ///< their kernel terms
  mutable std::vector<double> rows_[4];  ///< their Jacobian blocks, row-major
};

/// Support on a plane (fit_bounds.h): weight * (height of the superquadric's lowest extent
/// along `up` above the plane up . q + offset = 0), all in the start model's frame. The
/// lowest extent is up . c - h(R^T up), h the support function.
struct SuperquadricSupportResidual {
  SuperquadricSupportResidual(const Eigen::Vector3d& up, double offset, double weight)
      : up_(up), offset_(offset), weight_(weight) {}

  template <class T>
  bool operator()(const T* const a, const T* const e, const T* const w, const T* const t,
                  T* residual) const {
    const T u[3] = {T(up_.x()), T(up_.y()), T(up_.z())};
    const T minus_w[3] = {-w[0], -w[1], -w[2]};
    T v[3];
    ceres::AngleAxisRotatePoint(minus_w, u, v);  // Exp(w)^T up
    using std::exp;
    const T h = exp(logExtentCanonical(v[0], v[1], v[2], a[0], a[1], a[2], e[0], e[1]));
    residual[0] = T(weight_) * (u[0] * t[0] + u[1] * t[1] + u[2] * t[2] - h + T(offset_));
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector3d& up, double offset, double weight) {
    return new ceres::AutoDiffCostFunction<SuperquadricSupportResidual, 1, 3, 2, 3, 3>(
        new SuperquadricSupportResidual(up, offset, weight));
  }

  Eigen::Vector3d up_;
  double offset_, weight_;
};

}  // namespace novelty_detection
