// The first-order (gradient-normalised) surface distance as a least-squares residual with
// its analytic derivatives (superquadric_cost.h, SuperquadricSurfaceResidual).
#include <Eigen/Geometry>
#include <cmath>

#include "novelty_detection/shape/superquadric_cost.h"
#include "shape/pose_jacobian.h"
#include "shape/superquadric_kernel.h"

namespace novelty_detection {
namespace {

using detail::kTinyNorm2;
using detail::RotationTerms;
using detail::rotationTerms;

/// Residual of one point (start-frame coordinates q) and, when the pointers are not null,
/// its derivatives: ja[3] (sizes), je[2] (exponents), jw[3] (rotation), jt[3] (translation).
///
/// With lx = log((x/a1)^2)/e2, ly, lz = log((z/a3)^2)/e1 (guarded as in eq. 2), lxy =
/// lse(lx, ly), la = (e2/e1) lxy, l = log F = lse(la, lz), their softmax weights wx, wy, wa,
/// wb and hx = x / (x^2 + tiny a1^2) (likewise hy, hz):
///   grad_p log F = (2/e1) v,  v = (wa wx hx, wa wy hy, wb hz),
///   r = (1 - F^(-e1/2)) / (e1/2 |grad_p log F|) = (1 - exp(-e1 l / 2)) / |v|.
/// Each parameter's derivative follows from those of lx, ly, lz, hx, hy, hz through the
/// log-sum-exps (d wx = wx wy (d lx - d ly), d wa = wa wb (d la - d lz)).
double surfacePointResidual(const Eigen::Vector3d& q, const double* a, double e1, double e2,
                            const double* t, const RotationTerms& rt, double* ja, double* je,
                            double* jw, double* jt) {
  const Eigen::Vector3d p = detail::canonicalPoint(rt, q, t);
  const double x = p.x(), y = p.y(), z = p.z();
  const double bx = x * x + kSqTinySquared * a[0] * a[0];
  const double by = y * y + kSqTinySquared * a[1] * a[1];
  const double bz = z * z + kSqTinySquared * a[2] * a[2];
  const double lx = std::log(bx / (a[0] * a[0])) / e2;
  const double ly = std::log(by / (a[1] * a[1])) / e2;
  const double lz = std::log(bz / (a[2] * a[2])) / e1;
  const double hx = x / bx, hy = y / by, hz = z / bz;
  const bool x_big = lx > ly;
  const double ux = std::exp(x_big ? ly - lx : lx - ly);
  const double wx = (x_big ? 1.0 : ux) / (1.0 + ux), wy = 1.0 - wx;
  const double lxy = (x_big ? lx : ly) + std::log1p(ux);
  const double la = e2 / e1 * lxy;
  const bool a_big = la > lz;
  const double ua = std::exp(a_big ? lz - la : la - lz);
  const double wa = (a_big ? 1.0 : ua) / (1.0 + ua), wb = 1.0 - wa;
  const double l = (a_big ? la : lz) + std::log1p(ua);
  const double g = std::exp(-0.5 * e1 * l);
  const Eigen::Vector3d v(wa * wx * hx, wa * wy * hy, wb * hz);
  const double norm = std::sqrt(v.squaredNorm() + kTinyNorm2);
  const double r = (1.0 - g) / norm;
  if (!ja && !je && !jw && !jt) return r;

  // dr along one parameter from the derivatives of lx, ly, lz, hx, hy, hz, and whether the
  // parameter is e1 or e2 (which also enter la and the numerator directly).
  auto derivative = [&](double dlx, double dly, double dlz, double dhx, double dhy, double dhz,
                        double de1, double de2) {
    const double dlxy = wx * dlx + wy * dly;
    const double dwx = wx * wy * (dlx - dly);
    const double dla = e2 / e1 * dlxy + (de2 * lxy - de1 * la) / e1;
    const double dwa = wa * wb * (dla - dlz);
    const double dl = wa * dla + wb * dlz;
    const double dnum = 0.5 * g * (e1 * dl + de1 * l);
    const double dvx = dwa * wx * hx + wa * dwx * hx + wa * wx * dhx;
    const double dvy = dwa * wy * hy - wa * dwx * hy + wa * wy * dhy;
    const double dvz = -dwa * hz + wb * dhz;
    const double dnorm = (v.x() * dvx + v.y() * dvy + v.z() * dvz) / norm;
    return (dnum - r * dnorm) / norm;
  };
  if (ja) {
    ja[0] = derivative(-2.0 * x * hx / (a[0] * e2), 0, 0,
                       -2.0 * kSqTinySquared * a[0] * x / (bx * bx), 0, 0, 0, 0);
    ja[1] = derivative(0, -2.0 * y * hy / (a[1] * e2), 0, 0,
                       -2.0 * kSqTinySquared * a[1] * y / (by * by), 0, 0, 0);
    ja[2] = derivative(0, 0, -2.0 * z * hz / (a[2] * e1), 0, 0,
                       -2.0 * kSqTinySquared * a[2] * z / (bz * bz), 0, 0);
  }
  if (je) {
    je[0] = derivative(0, 0, -lz / e1, 0, 0, 0, 1, 0);
    je[1] = derivative(-lx / e2, -ly / e2, 0, 0, 0, 0, 0, 1);
  }
  if (!jw && !jt) return r;
  const Eigen::Vector3d dr_dp(
      derivative(2.0 * hx / e2, 0, 0, (bx - 2.0 * x * x) / (bx * bx), 0, 0, 0, 0),
      derivative(0, 2.0 * hy / e2, 0, 0, (by - 2.0 * y * y) / (by * by), 0, 0, 0),
      derivative(0, 0, 2.0 * hz / e1, 0, 0, (bz - 2.0 * z * z) / (bz * bz), 0, 0));
  detail::poseJacobian(rt, p, dr_dp, jw, jt);
  return r;
}

}  // namespace

SuperquadricSurfaceResidual::SuperquadricSurfaceResidual(const std::vector<Eigen::Vector3d>& q,
                                                         double weight)
    : q_(q), weight_(weight) {
  set_num_residuals(static_cast<int>(q.size()));
  *mutable_parameter_block_sizes() = {3, 2, 3, 3};
}

bool SuperquadricSurfaceResidual::Evaluate(double const* const* parameters, double* residuals,
                                           double** jacobians) const {
  const RotationTerms rt = rotationTerms(parameters[2]);
  for (std::size_t i = 0; i < q_.size(); ++i) {
    double* rows[4] = {nullptr, nullptr, nullptr, nullptr};
    for (int b = 0; jacobians && b < 4; ++b) {
      if (jacobians[b]) rows[b] = jacobians[b] + detail::kBlockSizes[b] * i;
    }
    residuals[i] =
        weight_ * surfacePointResidual(q_[i], parameters[0], parameters[1][0], parameters[1][1],
                                       parameters[3], rt, rows[0], rows[1], rows[2], rows[3]);
    detail::scaleJacobianRow(jacobians, static_cast<int>(i), weight_);
  }
  return true;
}

}  // namespace novelty_detection
