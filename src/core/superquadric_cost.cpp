#include "novelty_detection/superquadric_cost.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <utility>

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

/// The parts of Exp(w) and of its right Jacobian that depend on w alone (shared by all
/// points of one evaluation).
struct RotationTerms {
  Eigen::Vector3d w;
  double sa, sb;  ///< Exp(w) = I + sa [w]x + sb [w]x^2
  double c1, c2;  ///< J_r(w) = I - c1 [w]x + c2 [w]x^2
};

RotationTerms rotationTerms(const double* w_ptr) {
  RotationTerms r;
  r.w = Eigen::Vector3d(w_ptr[0], w_ptr[1], w_ptr[2]);
  const double theta2 = r.w.squaredNorm();
  const double theta = std::sqrt(theta2);
  if (theta < 1e-4) {  // series near zero
    r.sa = 1.0 - theta2 / 6.0;
    r.sb = 0.5 - theta2 / 24.0;
    r.c1 = 0.5 - theta2 / 24.0;
    r.c2 = 1.0 / 6.0 - theta2 / 120.0;
  } else {
    const double s = std::sin(theta), c = std::cos(theta);
    r.sa = s / theta;
    r.sb = (1.0 - c) / theta2;
    r.c1 = (1.0 - c) / theta2;
    r.c2 = (theta - s) / (theta2 * theta);
  }
  return r;
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

SuperquadricBatchResidual::SuperquadricBatchResidual(const std::vector<Eigen::Vector3d>& q)
    : q_(3, static_cast<Eigen::Index>(q.size())),
      terms_(static_cast<Eigen::Index>(q.size()), static_cast<Eigen::Index>(kTerms)) {
  for (std::size_t i = 0; i < q.size(); ++i) q_.col(static_cast<Eigen::Index>(i)) = q[i];
  set_num_residuals(static_cast<int>(q.size()));
  *mutable_parameter_block_sizes() = {3, 2, 3, 3};
}

bool SuperquadricBatchResidual::Evaluate(double const* const* parameters, double* residuals,
                                         double** jacobians) const {
  // Ceres evaluates the cost at a candidate step and, when it accepts the step, the Jacobian
  // at the same parameters: the terms (the logs and exps, most of the cost) are then reused.
  constexpr int kSizes[4] = {3, 2, 3, 3};
  bool same = cached_;
  for (int b = 0, m = 0; b < 4; ++b) {
    for (int k = 0; k < kSizes[b]; ++k, ++m) same = same && parameters[b][k] == last_[m];
  }
  const Eigen::Index n = q_.cols();
  if (!same) {
    for (Eigen::Index begin = 0; begin < n; begin += kChunk) {
      computeTerms(parameters, begin, std::min(kChunk, n - begin));
    }
    for (int b = 0, m = 0; b < 4; ++b) {
      for (int k = 0; k < kSizes[b]; ++k, ++m) last_[m] = parameters[b][k];
    }
    cached_ = true;
  }
  Eigen::Map<Eigen::VectorXd>(residuals, n) = terms_.col(kResidual);
  if (!jacobians) return true;
  for (Eigen::Index begin = 0; begin < n; begin += kChunk) {
    double* chunk[4] = {nullptr, nullptr, nullptr, nullptr};
    for (int b = 0; b < 4; ++b) {
      if (jacobians[b]) chunk[b] = jacobians[b] + kSizes[b] * begin;
    }
    jacobianChunk(parameters, begin, std::min(kChunk, n - begin), chunk);
  }
  return true;
}

// Chunks of at most kChunk points: the temporaries live on the stack. (Heap arrays over all
// points, freed and reallocated at every evaluation, made glibc return memory to the kernel
// each time past its trim threshold: on a loaded machine the unmapping and page faults took
// as much time as the arithmetic.)
using ChunkArray = Eigen::Array<double, Eigen::Dynamic, 1, Eigen::ColMajor, 64, 1>;

void SuperquadricBatchResidual::computeTerms(double const* const* parameters, Eigen::Index begin,
                                             Eigen::Index n) const {
  // pointResidual() for the chunk's points at once, as Eigen array expressions: the logs and
  // exps then run on SIMD packets.
  using A = ChunkArray;
  static_assert(A::MaxRowsAtCompileTime == kChunk, "chunk size");
  const RotationTerms rt = rotationTerms(parameters[2]);
  const double* a = parameters[0];
  const double e1 = parameters[1][0], e2 = parameters[1][1];
  const double* t = parameters[3];
  const double wx = rt.w.x(), wy = rt.w.y(), wz = rt.w.z();
  // p = Exp(w)^T (q - t) = d - sa (w x d) + sb w x (w x d).
  const A dx = q_.row(0).segment(begin, n).transpose().array() - t[0];
  const A dy = q_.row(1).segment(begin, n).transpose().array() - t[1];
  const A dz = q_.row(2).segment(begin, n).transpose().array() - t[2];
  const A cx = wy * dz - wz * dy, cy = wz * dx - wx * dz, cz = wx * dy - wy * dx;
  const A px = dx - rt.sa * cx + rt.sb * (wy * cz - wz * cy);
  const A py = dy - rt.sa * cy + rt.sb * (wz * cx - wx * cz);
  const A pz = dz - rt.sa * cz + rt.sb * (wx * cy - wy * cx);
  const A sx = px.square() / (a[0] * a[0]), sy = py.square() / (a[1] * a[1]);
  const A sz = pz.square() / (a[2] * a[2]);
  const A rx = sx + kSqTinySquared, ry = sy + kSqTinySquared, rz = sz + kSqTinySquared;
  const A lx = rx.log() / e2, ly = ry.log() / e2, lb = rz.log() / e1;
  // Two log-sum-exps with their softmax weights (logSumExpWeights()).
  const A u1 = (-(lx - ly).abs()).exp(), s1 = 1.0 + u1;
  const A lxy = lx.max(ly) + s1.log();
  const A la = (e2 / e1) * lxy;
  const A u2 = (-(la - lb).abs()).exp(), s2 = 1.0 + u2;
  const A l = la.max(lb) + s2.log();
  const A big_e = (e1 * l).exp();
  auto term = [&](Term k) { return terms_.col(k).segment(begin, n).array(); };
  term(kPx) = px;
  term(kPy) = py;
  term(kPz) = pz;
  term(kLx) = lx;
  term(kLy) = ly;
  term(kLb) = lb;
  term(kLxy) = lxy;
  term(kLa) = la;
  term(kL) = l;
  term(kWxw) = (lx > ly).select(A::Ones(n), u1) / s1;
  term(kWyw) = (lx > ly).select(u1, A::Ones(n)) / s1;
  term(kWa) = (la > lb).select(A::Ones(n), u2) / s2;
  term(kWb) = (la > lb).select(u2, A::Ones(n)) / s2;
  term(kBigE) = big_e;
  term(kResidual) = std::sqrt(a[0] * a[1] * a[2]) * (big_e - 1.0);
}

void SuperquadricBatchResidual::jacobianChunk(double const* const* parameters, Eigen::Index begin,
                                              Eigen::Index n, double** jacobians) const {
  using A = ChunkArray;
  const RotationTerms rt = rotationTerms(parameters[2]);
  const double* a = parameters[0];
  const double e1 = parameters[1][0];
  const double wx = rt.w.x(), wy = rt.w.y(), wz = rt.w.z();
  auto term = [&](Term k) { return terms_.col(k).segment(begin, n).array(); };
  const A px = term(kPx), py = term(kPy), pz = term(kPz);
  const A sx = px.square() / (a[0] * a[0]), sy = py.square() / (a[1] * a[1]);
  const A sz = pz.square() / (a[2] * a[2]);
  const A rx = sx + kSqTinySquared, ry = sy + kSqTinySquared, rz = sz + kSqTinySquared;
  const A wxw = term(kWxw), wyw = term(kWyw), wa = term(kWa), wb = term(kWb);
  const A big_e = term(kBigE);
  const double big_s = std::sqrt(a[0] * a[1] * a[2]);
  const A k = big_s * e1 * big_e;  // dr/dL
  const A gx = k * wa * wxw * (2.0 / e1) * (px / (a[0] * a[0])) / rx;
  const A gy = k * wa * wyw * (2.0 / e1) * (py / (a[1] * a[1])) / ry;
  const A gz = k * wb * (2.0 / e1) * (pz / (a[2] * a[2])) / rz;
  // Ceres' Jacobian blocks are row-major: row i of block b starts at i * size(b).
  if (jacobians[0]) {
    const A half = 0.5 * big_s * (big_e - 1.0);
    const A ja0 = half / a[0] - k * wa * wxw * (2.0 / (e1 * a[0])) * sx / rx;
    const A ja1 = half / a[1] - k * wa * wyw * (2.0 / (e1 * a[1])) * sy / ry;
    const A ja2 = half / a[2] - k * wb * (2.0 / (e1 * a[2])) * sz / rz;
    for (Eigen::Index i = 0; i < n; ++i) {
      jacobians[0][3 * i] = ja0[i];
      jacobians[0][3 * i + 1] = ja1[i];
      jacobians[0][3 * i + 2] = ja2[i];
    }
  }
  if (jacobians[1]) {
    const A se = big_s * big_e;
    const A je0 = se * (term(kL) - wa * term(kLa) - wb * term(kLb));
    const A je1 = se * wa * (term(kLxy) - wxw * term(kLx) - wyw * term(kLy));
    for (Eigen::Index i = 0; i < n; ++i) {
      jacobians[1][2 * i] = je0[i];
      jacobians[1][2 * i + 1] = je1[i];
    }
  }
  if (jacobians[2]) {
    // h = dr_dp x p; J_r^T h = h + c1 (w x h) + c2 w x (w x h).
    const A hx = gy * pz - gz * py, hy = gz * px - gx * pz, hz = gx * py - gy * px;
    const A mx = wy * hz - wz * hy, my = wz * hx - wx * hz, mz = wx * hy - wy * hx;
    const A jx = hx + rt.c1 * mx + rt.c2 * (wy * mz - wz * my);
    const A jy = hy + rt.c1 * my + rt.c2 * (wz * mx - wx * mz);
    const A jz = hz + rt.c1 * mz + rt.c2 * (wx * my - wy * mx);
    for (Eigen::Index i = 0; i < n; ++i) {
      jacobians[2][3 * i] = jx[i];
      jacobians[2][3 * i + 1] = jy[i];
      jacobians[2][3 * i + 2] = jz[i];
    }
  }
  if (jacobians[3]) {
    // -(Exp(w) dr_dp) = -(v + sa (w x v) + sb w x (w x v)).
    const A vx = wy * gz - wz * gy, vy = wz * gx - wx * gz, vz = wx * gy - wy * gx;
    const A jx = -(gx + rt.sa * vx + rt.sb * (wy * vz - wz * vy));
    const A jy = -(gy + rt.sa * vy + rt.sb * (wz * vx - wx * vz));
    const A jz = -(gz + rt.sa * vz + rt.sb * (wx * vy - wy * vx));
    for (Eigen::Index i = 0; i < n; ++i) {
      jacobians[3][3 * i] = jx[i];
      jacobians[3][3 * i + 1] = jy[i];
      jacobians[3][3 * i + 2] = jz[i];
    }
  }
}

}  // namespace novelty_detection
