// Jacobian helpers of the superquadric cost functions (not of the SIMD kernel): the rotation
// and translation rows from a residual's gradient in the canonical frame, and the scaling of
// one residual's rows in Ceres' blocks.
#pragma once

#include <Eigen/Geometry>

#include "shape/least_squares.h"
#include "shape/superquadric_kernel.h"

namespace novelty_detection {
namespace detail {

/// The canonical point p = Exp(w)^T (q - t) = d - sa (w x d) + sb w x (w x d), d = q - t.
inline Eigen::Vector3d canonicalPoint(const RotationTerms& rt, const Eigen::Vector3d& q,
                                      const double* t) {
  const Eigen::Vector3d d(q.x() - t[0], q.y() - t[1], q.z() - t[2]);
  const Eigen::Vector3d wxd = rt.w.cross(d);
  return d - rt.sa * wxd + rt.sb * rt.w.cross(wxd);
}

/// p = Exp(w)^T (q - t) the canonical point, dr_dp the residual's gradient there; fills
/// jw[3] = dr/dw and jt[3] = dr/dt when not null.
inline void poseJacobian(const RotationTerms& rt, const Eigen::Vector3d& p,
                         const Eigen::Vector3d& dr_dp, double* jw, double* jt) {
  const Eigen::Vector3d& w = rt.w;
  if (jw) {
    // dr/dw = dr_dp^T [p]x J_r(w); as a row vector g^T J_r = (J_r^T g)^T with
    // J_r^T g = g + c1 (w x g) + c2 w x (w x g), and (dr_dp^T [p]x)^T = dr_dp x p.
    const Eigen::Vector3d h = dr_dp.cross(p);
    const Eigen::Vector3d wxh = w.cross(h);
    const Eigen::Vector3d g = h + rt.c1 * wxh + rt.c2 * w.cross(wxh);
    for (int i = 0; i < 3; ++i) jw[i] = g[i];
  }
  if (jt) {
    // dr/dt = -(Exp(w) dr_dp)^T; Exp(w) v = v + sa (w x v) + sb w x (w x v).
    const Eigen::Vector3d wxv = w.cross(dr_dp);
    const Eigen::Vector3d g = -(dr_dp + rt.sa * wxv + rt.sb * w.cross(wxv));
    for (int i = 0; i < 3; ++i) jt[i] = g[i];
  }
}

/// Multiplies residual i's rows of the (row-major, possibly null) Jacobian blocks by `factor`.
inline void scaleJacobianRow(double** jacobians, int i, double factor) {
  if (!jacobians) return;
  for (int b = 0; b < 4; ++b) {
    if (!jacobians[b]) continue;
    for (int k = 0; k < kBlockSizes[b]; ++k) jacobians[b][i * kBlockSizes[b] + k] *= factor;
  }
}

}  // namespace detail
}  // namespace novelty_detection
