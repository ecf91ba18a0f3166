#include "novelty_detection/ros/superquadric_mesh.h"

#include <algorithm>
#include <cmath>

namespace novelty_detection {
namespace {

// Signed power sgn(v)|v|^e; |v| is clamped so pow() never sees a negative base.
double signedPow(double v, double e) {
  const double m = std::pow(std::max(std::abs(v), 0.0), e);
  return v < 0.0 ? -m : m;
}

}  // namespace

std::vector<Eigen::Vector3d> superquadricTriangles(const Superquadric& sq, int rings,
                                                   int segments) {
  rings = std::max(rings, 2);
  segments = std::max(segments, 3);
  const double e1 = std::max(sq.e1, 1e-3), e2 = std::max(sq.e2, 1e-3);
  const Eigen::Matrix3d R = sq.rotation();
  // Grid of surface points; row 0 is the south pole, row `rings` the north pole.
  std::vector<Eigen::Vector3d> grid((rings + 1) * segments);
  for (int i = 0; i <= rings; ++i) {
    const double eta = -M_PI / 2 + M_PI * i / rings;
    // The poles are exact: cos(pi/2) is ~6e-17 in floating point, and its power with a small
    // exponent is far from 0, which would open a hole where the pole fans are skipped.
    const bool pole = i == 0 || i == rings;
    const double ce = pole ? 0.0 : signedPow(std::cos(eta), e1);
    const double se = pole ? (i == 0 ? -1.0 : 1.0) : signedPow(std::sin(eta), e1);
    for (int j = 0; j < segments; ++j) {
      const double w = -M_PI + 2 * M_PI * j / segments;
      const Eigen::Vector3d p(sq.a.x() * ce * signedPow(std::cos(w), e2),
                              sq.a.y() * ce * signedPow(std::sin(w), e2), sq.a.z() * se);
      grid[i * segments + j] = R * p + sq.position;
    }
  }
  // d/dw points east and d/deta north, east x north points outwards: the triangles
  // (i,j) (i,j+1) (i+1,j+1) and (i,j) (i+1,j+1) (i+1,j) are counter-clockwise from outside.
  std::vector<Eigen::Vector3d> tris;
  tris.reserve(rings * segments * 6);
  for (int i = 0; i < rings; ++i) {
    for (int j = 0; j < segments; ++j) {
      const int jn = (j + 1) % segments;
      const auto& p00 = grid[i * segments + j];
      const auto& p01 = grid[i * segments + jn];
      const auto& p10 = grid[(i + 1) * segments + j];
      const auto& p11 = grid[(i + 1) * segments + jn];
      if (i > 0) tris.insert(tris.end(), {p00, p01, p11});  // skip zero-area pole fans
      if (i + 1 < rings) tris.insert(tris.end(), {p00, p11, p10});
    }
  }
  return tris;
}

}  // namespace novelty_detection
