// Kernels of the batched superquadric residual (superquadric_cost.h) and of the normal
// equations of the fits' least-squares steps (least_squares.h), in their own file
// (superquadric_cost_kernel.cpp) so that it can be compiled for wider SIMD: raw pointers
// only, no Eigen object allocated on one side and freed on the other.
#pragma once

#include <Eigen/Core>

namespace novelty_detection {
namespace detail {

/// The parts of Exp(w) and of its right Jacobian that depend on w alone (shared by all
/// points of one evaluation).
struct RotationTerms {
  Eigen::Vector3d w;
  double sa, sb;  ///< Exp(w) = I + sa [w]x + sb [w]x^2
  double c1, c2;  ///< J_r(w) = I - c1 [w]x + c2 [w]x^2
};

/// Exp(w) and J_r(w) terms of a rotation vector w[3].
RotationTerms rotationTerms(const double* w_ptr);

/// Where a kernel writes a chunk's Jacobian rows: the entry of the chunk's point i and of
/// parameter k of block b (sizes 3, 2, 3, 3) at block[b][i * row_stride[b] + k *
/// col_stride[b]]; null blocks are skipped. Ceres' row-major blocks: row_stride = size(b),
/// col_stride = 1; one column-major matrix of height h: row_stride = 1, col_stride = h, each
/// column a contiguous run. Plain data: this header is also compiled for wider SIMD.
struct JacobianOut {
  double* block[4] = {nullptr, nullptr, nullptr, nullptr};
  Eigen::Index row_stride[4] = {};
  Eigen::Index col_stride[4] = {};
};

/// Points per chunk of an evaluation (a multiple of the SIMD packet size).
constexpr Eigen::Index kKernelChunk = 64;
/// Per point terms of the residual that the Jacobian reuses, and the residual: the columns
/// of the terms matrix (points x kTerms, column-major).
enum KernelTerm {
  kPx,
  kPy,
  kPz,
  kLx,
  kLy,
  kLb,
  kLxy,
  kLa,
  kL,
  kWxw,
  kWyw,
  kWa,
  kWb,
  kBigE,
  kResidual,
  kTerms
};

/// Terms of points [begin, begin + n), n <= kKernelChunk, at `parameters` (sizes a[3],
/// exponents e[2], rotation vector w[3], translation t[3]). `q`: the 3 x rows start-frame
/// points (column-major), `terms`: rows x kTerms (column-major).
void superquadricTerms(double const* const* parameters, const double* q, double* terms,
                       Eigen::Index rows, Eigen::Index begin, Eigen::Index n);
/// Jacobian rows of points [begin, begin + n) from their terms; `out` starts at the chunk's
/// first row.
void superquadricJacobian(double const* const* parameters, const double* terms, Eigen::Index rows,
                          Eigen::Index begin, Eigen::Index n, const JacobianOut& out);

/// Keeps the first-order surface distance finite at the centre, where the gradient of log F
/// vanishes.
constexpr double kTinyNorm2 = 1e-24;

/// weight times the first-order surface distances of points [begin, begin + n) and their
/// Jacobian rows, from eq. 3's terms at the same parameters (the same formulas as
/// SuperquadricSurfaceResidual, equal up to rounding). `residuals` and `out` (null: residuals
/// only) start at the chunk's first row.
void superquadricSurfaceResiduals(double const* const* parameters, const double* terms,
                                  Eigen::Index rows, Eigen::Index begin, Eigen::Index n,
                                  double weight, double* residuals, const JacobianOut* out);

/// Distances of points to a superquadric, vectorised (the same formulas as radialDistance()
/// and surfaceDistance() in superquadric.cpp, equal to them up to rounding). `shape`: a1, a2,
/// a3, e1, e2; `rotation`: R (3 x 3, column-major); `centre`: its position; `points`: n
/// consecutive xyz triples, or with `index` (may be null) the triples at index[0..n).
/// surface = true: first-order surface distance, else radial distance; into out[0..n).
void superquadricDistances(const double* shape, const double* rotation, const double* centre,
                           const double* points, const int* index, Eigen::Index n, bool surface,
                           double* out);

/// The normal equations of a least-squares step from a column-major rows x cols Jacobian J
/// (leading dimension rows) and the residuals r: J^T J into jtj (cols x cols, column-major;
/// both triangles) and J^T r into jtr (cols). Each entry is one dot product of two columns,
/// the upper triangle only (the lower one copied), vectorised.
void normalEquations(const double* jacobian, const double* residuals, Eigen::Index rows,
                     Eigen::Index cols, double* jtj, double* jtr);

}  // namespace detail
}  // namespace novelty_detection
