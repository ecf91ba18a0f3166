#include "novelty_detection/superquadric_cost.h"

#include <Eigen/Geometry>
#include <cmath>

namespace novelty_detection {
namespace {

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

}  // namespace

bool SuperquadricAnalyticResidual::Evaluate(double const* const* parameters, double* residuals,
                                            double** jacobians) const {
  const double* a = parameters[0];
  const double e1 = parameters[1][0], e2 = parameters[1][1];
  const Eigen::Map<const Eigen::Vector3d> w(parameters[2]);
  const Eigen::Map<const Eigen::Vector3d> t(parameters[3]);

  // Exp(w) by Rodrigues (series near zero); p = Exp(w)^T (q - t).
  const double theta2 = w.squaredNorm();
  const double theta = std::sqrt(theta2);
  double sa, sb;  // Exp(w) = I + sa [w]x + sb [w]x^2
  if (theta < 1e-4) {
    sa = 1.0 - theta2 / 6.0;
    sb = 0.5 - theta2 / 24.0;
  } else {
    sa = std::sin(theta) / theta;
    sb = (1.0 - std::cos(theta)) / theta2;
  }
  const Eigen::Vector3d d = q_ - t;
  // Exp(w)^T d = d - sa (w x d) + sb w x (w x d).
  const Eigen::Vector3d wxd = w.cross(d);
  const Eigen::Vector3d p = d - sa * wxd + sb * w.cross(wxd);

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
  residuals[0] = big_s * (big_e - 1.0);
  if (!jacobians) return true;

  const double k = big_s * big_e * e1;  // dr/dL
  // dL/dp: d lx / dx = (2 / e2) (x / a1^2) / rx, weighted through the two log-sum-exps.
  const Eigen::Vector3d grad(wa * wxw * (2.0 / e1) * (p.x() / (a[0] * a[0])) / rx,
                             wa * wyw * (2.0 / e1) * (p.y() / (a[1] * a[1])) / ry,
                             wb * (2.0 / e1) * (p.z() / (a[2] * a[2])) / rz);
  const Eigen::Vector3d dr_dp = k * grad;
  if (jacobians[0]) {
    const double half = 0.5 * big_s * (big_e - 1.0);
    jacobians[0][0] = half / a[0] - k * wa * wxw * (2.0 / (e1 * a[0])) * sx / rx;
    jacobians[0][1] = half / a[1] - k * wa * wyw * (2.0 / (e1 * a[1])) * sy / ry;
    jacobians[0][2] = half / a[2] - k * wb * (2.0 / (e1 * a[2])) * sz / rz;
  }
  if (jacobians[1]) {
    jacobians[1][0] = big_s * big_e * (l - wa * la - wb * lb);
    jacobians[1][1] = big_s * big_e * wa * (lxy - wxw * lx - wyw * ly);
  }
  if (jacobians[2]) {
    // dr/dw = dr_dp^T [p]x J_r(w), J_r = I - c1 [w]x + c2 [w]x^2; as a row vector
    // g^T J_r = (J_r^T g)^T with J_r^T g = g + c1 (w x g) + c2 w x (w x g).
    double c1, c2;
    if (theta < 1e-4) {
      c1 = 0.5 - theta2 / 24.0;
      c2 = 1.0 / 6.0 - theta2 / 120.0;
    } else {
      c1 = (1.0 - std::cos(theta)) / theta2;
      c2 = (theta - std::sin(theta)) / (theta2 * theta);
    }
    // (dr_dp^T [p]x)^T = [p]x^T dr_dp = dr_dp x p.
    const Eigen::Vector3d h = dr_dp.cross(p);
    const Eigen::Vector3d wxh = w.cross(h);
    const Eigen::Vector3d jw = h + c1 * wxh + c2 * w.cross(wxh);
    for (int i = 0; i < 3; ++i) jacobians[2][i] = jw[i];
  }
  if (jacobians[3]) {
    // dr/dt = -(Exp(w) dr_dp)^T; Exp(w) v = v + sa (w x v) + sb w x (w x v).
    const Eigen::Vector3d wxv = w.cross(dr_dp);
    const Eigen::Vector3d jt = -(dr_dp + sa * wxv + sb * w.cross(wxv));
    for (int i = 0; i < 3; ++i) jacobians[3][i] = jt[i];
  }
  return true;
}

}  // namespace novelty_detection
