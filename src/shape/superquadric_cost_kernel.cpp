// Vectorised kernels of SuperquadricBatchResidual (superquadric_cost.h): eq. 3's residual
// and its Jacobian over chunks of points, and the normal equations of a least-squares step
// (J^T J, J^T r). This file may be compiled for wider SIMD than the
// rest of the library (CMake option NOVELTY_AVX2), so its interface is raw pointers and it
// allocates nothing on the heap: no Eigen object crosses between code built for different
// alignments.
#include "shape/superquadric_kernel.h"

#include <algorithm>
#include <cmath>

#include "novelty_detection/shape/superquadric.h"

namespace novelty_detection {
namespace detail {

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

// Chunks of at most kKernelChunk points: the temporaries live on the stack. (Heap arrays over all
// points, freed and reallocated at every evaluation, made glibc return memory to the kernel
// each time past its trim threshold: on a loaded machine the unmapping and page faults took
// as much time as the arithmetic.)
using ChunkArray = Eigen::Array<double, Eigen::Dynamic, 1, Eigen::ColMajor, kKernelChunk, 1>;

namespace {

/// Column k of block b of the chunk's n rows.
void store(const JacobianOut& out, int b, int k, const ChunkArray& v, Eigen::Index n) {
  double* first = out.block[b] + k * out.col_stride[b];
  if (out.row_stride[b] == 1) {
    Eigen::Map<Eigen::ArrayXd>(first, n) = v.head(n);
  } else {
    for (Eigen::Index i = 0; i < n; ++i) first[i * out.row_stride[b]] = v[i];
  }
}

/// Rotation and translation rows (blocks 2 and 3 of `out`, null ones skipped) of residuals
/// whose gradient in the canonical frame is (gx, gy, gz) at the points (px, py, pz).
void writePoseRows(const RotationTerms& rt, const ChunkArray& px, const ChunkArray& py,
                   const ChunkArray& pz, const ChunkArray& gx, const ChunkArray& gy,
                   const ChunkArray& gz, Eigen::Index n, const JacobianOut& out) {
  using A = ChunkArray;
  const double wx = rt.w.x(), wy = rt.w.y(), wz = rt.w.z();
  if (out.block[2]) {
    // h = dr_dp x p; J_r^T h = h + c1 (w x h) + c2 w x (w x h).
    const A hx = gy * pz - gz * py, hy = gz * px - gx * pz, hz = gx * py - gy * px;
    const A mx = wy * hz - wz * hy, my = wz * hx - wx * hz, mz = wx * hy - wy * hx;
    store(out, 2, 0, hx + rt.c1 * mx + rt.c2 * (wy * mz - wz * my), n);
    store(out, 2, 1, hy + rt.c1 * my + rt.c2 * (wz * mx - wx * mz), n);
    store(out, 2, 2, hz + rt.c1 * mz + rt.c2 * (wx * my - wy * mx), n);
  }
  if (out.block[3]) {
    // -(Exp(w) dr_dp) = -(v + sa (w x v) + sb w x (w x v)).
    const A vx = wy * gz - wz * gy, vy = wz * gx - wx * gz, vz = wx * gy - wy * gx;
    store(out, 3, 0, -(gx + rt.sa * vx + rt.sb * (wy * vz - wz * vy)), n);
    store(out, 3, 1, -(gy + rt.sa * vy + rt.sb * (wz * vx - wx * vz)), n);
    store(out, 3, 2, -(gz + rt.sa * vz + rt.sb * (wx * vy - wy * vx)), n);
  }
}

}  // namespace

void superquadricTerms(double const* const* parameters, const double* q_data, double* terms_data,
                       Eigen::Index rows, Eigen::Index begin, Eigen::Index n) {
  const Eigen::Map<const Eigen::Matrix3Xd> q_(q_data, 3, rows);
  Eigen::Map<Eigen::MatrixXd> terms_(terms_data, rows, kTerms);
  // pointResidual() for the chunk's points at once, as Eigen array expressions: the logs and
  // exps then run on SIMD packets.
  using A = ChunkArray;
  static_assert(A::MaxRowsAtCompileTime == kKernelChunk, "chunk size");
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
  auto term = [&](KernelTerm k) { return terms_.col(k).segment(begin, n).array(); };
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

void superquadricJacobian(double const* const* parameters, const double* terms_data,
                          Eigen::Index rows, Eigen::Index begin, Eigen::Index n,
                          const JacobianOut& out) {
  const Eigen::Map<const Eigen::MatrixXd> terms_(terms_data, rows, kTerms);
  using A = ChunkArray;
  const RotationTerms rt = rotationTerms(parameters[2]);
  const double* a = parameters[0];
  const double e1 = parameters[1][0];
  auto term = [&](KernelTerm k) { return terms_.col(k).segment(begin, n).array(); };
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
  if (out.block[0]) {
    const A half = 0.5 * big_s * (big_e - 1.0);
    store(out, 0, 0, half / a[0] - k * wa * wxw * (2.0 / (e1 * a[0])) * sx / rx, n);
    store(out, 0, 1, half / a[1] - k * wa * wyw * (2.0 / (e1 * a[1])) * sy / ry, n);
    store(out, 0, 2, half / a[2] - k * wb * (2.0 / (e1 * a[2])) * sz / rz, n);
  }
  if (out.block[1]) {
    const A se = big_s * big_e;
    store(out, 1, 0, se * (term(kL) - wa * term(kLa) - wb * term(kLb)), n);
    store(out, 1, 1, se * wa * (term(kLxy) - wxw * term(kLx) - wyw * term(kLy)), n);
  }
  writePoseRows(rt, px, py, pz, gx, gy, gz, n, out);
}

void superquadricSurfaceResiduals(double const* const* parameters, const double* terms_data,
                                  Eigen::Index rows, Eigen::Index begin, Eigen::Index n,
                                  double weight, double* residuals, const JacobianOut* out) {
  const Eigen::Map<const Eigen::MatrixXd> terms_(terms_data, rows, kTerms);
  using A = ChunkArray;
  const double* a = parameters[0];
  const double e1 = parameters[1][0], e2 = parameters[1][1];
  auto term = [&](KernelTerm k) { return terms_.col(k).segment(begin, n).array(); };
  // The scalar residual's quantities (superquadric_surface_cost.cpp): its logs, weights and
  // log F are eq. 3's terms; hx = x / (x^2 + tiny a1^2), likewise hy, hz.
  const A px = term(kPx), py = term(kPy), pz = term(kPz);
  const A bx = px.square() + kSqTinySquared * a[0] * a[0];
  const A by = py.square() + kSqTinySquared * a[1] * a[1];
  const A bz = pz.square() + kSqTinySquared * a[2] * a[2];
  const A hx = px / bx, hy = py / by, hz = pz / bz;
  const A lx = term(kLx), ly = term(kLy), lz = term(kLb), lxy = term(kLxy), la = term(kLa);
  const A l = term(kL), wx = term(kWxw), wy = term(kWyw), wa = term(kWa), wb = term(kWb);
  const A g = (-0.5 * e1 * l).exp();
  const A vx = wa * wx * hx, vy = wa * wy * hy, vz = wb * hz;
  const A norm = (vx.square() + vy.square() + vz.square() + kTinyNorm2).sqrt();
  const A r = (1.0 - g) / norm;
  Eigen::Map<Eigen::ArrayXd>(residuals, n) = weight * r;
  if (!out) return;

  // weight * dr along one parameter from the derivatives of lx, ly, lz, hx, hy, hz and
  // whether the parameter is e1 or e2 (which also enter la and the numerator directly).
  const A zero = A::Zero(n);
  auto derivative = [&](const A& dlx, const A& dly, const A& dlz, const A& dhx, const A& dhy,
                        const A& dhz, double de1, double de2) -> A {
    const A dlxy = wx * dlx + wy * dly;
    const A dwx = wx * wy * (dlx - dly);
    const A dla = e2 / e1 * dlxy + (de2 * lxy - de1 * la) / e1;
    const A dwa = wa * wb * (dla - dlz);
    const A dl = wa * dla + wb * dlz;
    const A dnum = 0.5 * g * (e1 * dl + de1 * l);
    const A dvx = dwa * wx * hx + wa * dwx * hx + wa * wx * dhx;
    const A dvy = dwa * wy * hy - wa * dwx * hy + wa * wy * dhy;
    const A dvz = -dwa * hz + wb * dhz;
    const A dnorm = (vx * dvx + vy * dvy + vz * dvz) / norm;
    return weight * (dnum - r * dnorm) / norm;
  };
  if (out->block[0]) {
    store(*out, 0, 0,
          derivative(-2.0 * px * hx / (a[0] * e2), zero, zero,
                     -2.0 * kSqTinySquared * a[0] * px / bx.square(), zero, zero, 0, 0),
          n);
    store(*out, 0, 1,
          derivative(zero, -2.0 * py * hy / (a[1] * e2), zero, zero,
                     -2.0 * kSqTinySquared * a[1] * py / by.square(), zero, 0, 0),
          n);
    store(*out, 0, 2,
          derivative(zero, zero, -2.0 * pz * hz / (a[2] * e1), zero, zero,
                     -2.0 * kSqTinySquared * a[2] * pz / bz.square(), 0, 0),
          n);
  }
  if (out->block[1]) {
    store(*out, 1, 0, derivative(zero, zero, -lz / e1, zero, zero, zero, 1, 0), n);
    store(*out, 1, 1, derivative(-lx / e2, -ly / e2, zero, zero, zero, zero, 0, 1), n);
  }
  if (!out->block[2] && !out->block[3]) return;
  // The gradient in the canonical frame (already weighted).
  const A gx = derivative(2.0 * hx / e2, zero, zero, (bx - 2.0 * px.square()) / bx.square(), zero,
                          zero, 0, 0);
  const A gy = derivative(zero, 2.0 * hy / e2, zero, zero, (by - 2.0 * py.square()) / by.square(),
                          zero, 0, 0);
  const A gz = derivative(zero, zero, 2.0 * hz / e1, zero, zero,
                          (bz - 2.0 * pz.square()) / bz.square(), 0, 0);
  writePoseRows(rotationTerms(parameters[2]), px, py, pz, gx, gy, gz, n, *out);
}

void superquadricDistances(const double* shape, const double* rotation, const double* centre,
                           const double* points, const int* index, Eigen::Index n, bool surface,
                           double* out) {
  using A = ChunkArray;
  constexpr double kMaxLog = 690.0;  // exp() of more overflows (as in superquadric.cpp)
  const double a0 = shape[0], a1 = shape[1], a2 = shape[2], e1 = shape[3], e2 = shape[4];
  const double a_min = std::min(a0, std::min(a1, a2));
  A qx(kKernelChunk), qy(kKernelChunk), qz(kKernelChunk);
  for (Eigen::Index begin = 0; begin < n; begin += kKernelChunk) {
    const Eigen::Index m = std::min(kKernelChunk, n - begin);
    qx.resize(m);
    qy.resize(m);
    qz.resize(m);
    for (Eigen::Index i = 0; i < m; ++i) {
      const double* p = points + 3 * (index ? index[begin + i] : begin + i);
      const double dx = p[0] - centre[0], dy = p[1] - centre[1], dz = p[2] - centre[2];
      // q = R^T (p - c): the columns of R dotted with d.
      qx[i] = rotation[0] * dx + rotation[1] * dy + rotation[2] * dz;
      qy[i] = rotation[3] * dx + rotation[4] * dy + rotation[5] * dz;
      qz[i] = rotation[6] * dx + rotation[7] * dy + rotation[8] * dz;
    }
    // log F (logInsideOutsideCanonical()).
    const A lx = (qx.square() / (a0 * a0) + kSqTinySquared).log() / e2;
    const A ly = (qy.square() / (a1 * a1) + kSqTinySquared).log() / e2;
    const A lz = (qz.square() / (a2 * a2) + kSqTinySquared).log() / e1;
    const A lxy = lx.max(ly) + (1.0 + (-(lx - ly).abs()).exp()).log();
    const A la = (e2 / e1) * lxy;
    const A l = la.max(lz) + (1.0 + (-(la - lz).abs()).exp()).log();
    // Results are evaluated into chunk arrays (aligned storage) and then copied: evaluated
    // straight into `out`, Eigen would peel a few leading elements to reach alignment and
    // compute them with scalar exp/log, so the last bits of a distance would depend on the
    // address of the caller's buffer (and so on which thread allocated it).
    Eigen::Map<Eigen::ArrayXd> result(out + begin, m);
    auto radial = [&]() -> A {
      // | |q| - r_s |, r_s = |q| F^(-e1/2); the smallest half size at the centre.
      const A norm = (qx.square() + qy.square() + qz.square()).sqrt();
      const A r = (norm - (norm.log() - 0.5 * e1 * l).min(kMaxLog).exp()).abs();
      return (norm < 1e-12 * a_min).select(A::Constant(m, a_min), r);
    };
    if (!surface) {
      result = radial();
      continue;
    }
    // |f| / |grad f|, f = F^(e1/2) - 1, from the gradient of log F.
    const A wa = (la - l).exp(), wb = (lz - l).exp();
    const A wx = (lx - lxy).exp(), wy = (ly - lxy).exp();
    const A gx = wa * wx * 2.0 / e1 * qx / (qx.square() + kSqTinySquared * a0 * a0);
    const A gy = wa * wy * 2.0 / e1 * qy / (qy.square() + kSqTinySquared * a1 * a1);
    const A gz = wb * 2.0 / e1 * qz / (qz.square() + kSqTinySquared * a2 * a2);
    const A g = (gx.square() + gy.square() + gz.square()).sqrt();
    A d = (1.0 - (-0.5 * e1 * l).min(kMaxLog).exp()).abs() / (0.5 * e1 * g);
    if (!d.isFinite().all()) {
      const A r = radial();
      for (Eigen::Index i = 0; i < m; ++i) {
        if (!std::isfinite(d[i])) d[i] = r[i];
      }
    }
    result = d;
  }
}

void normalEquations(const double* jacobian, const double* residuals, Eigen::Index rows,
                     Eigen::Index cols, double* jtj, double* jtr) {
  using Column = Eigen::Map<const Eigen::VectorXd>;
  const Column r(residuals, rows);
  for (Eigen::Index i = 0; i < cols; ++i) {
    const Column ci(jacobian + i * rows, rows);
    for (Eigen::Index j = i; j < cols; ++j)
      jtj[i + j * cols] = jtj[j + i * cols] = ci.dot(Column(jacobian + j * rows, rows));
    jtr[i] = ci.dot(r);
  }
}

}  // namespace detail
}  // namespace novelty_detection
