// Superquadric geometry against known answers: eq. 2's inside/on/outside, guarded powers,
// radial distance, closed-form volume, mesh closure and winding, ZYZ Euler round trips.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <utility>

#include "novelty_detection/shape/superquadric.h"
#include "superquadric_samples.h"

using namespace novelty_detection;
using samples::makeSq;

namespace {
constexpr double kPi = 3.14159265358979323846;

std::vector<Superquadric> shapeFamily() {
  return {makeSq({0.3, 0.2, 0.5}, 0.1, 0.1),   // box-like
          makeSq({0.2, 0.2, 0.6}, 0.1, 1.0),   // cylinder
          makeSq({0.4, 0.4, 0.4}, 1.0, 1.0),   // sphere
          makeSq({0.5, 0.3, 0.2}, 1.0, 1.0),   // ellipsoid
          makeSq({0.3, 0.4, 0.25}, 1.8, 1.8),  // octahedron-like
          makeSq({0.3, 0.2, 0.4}, 0.3, 1.5)};
}
}  // namespace

TEST(Superquadric, InsideOnOutsideClassification) {
  std::mt19937 rng(1);
  for (Superquadric sq : shapeFamily()) {
    samples::randomPose(sq, rng);
    for (const auto& p : sampleSurfaceRandom(sq, 300, 3u)) {
      EXPECT_NEAR(insideOutside(sq, p), 1.0, 1e-9);
      EXPECT_NEAR(radialDistance(sq, p), 0.0, 1e-9);
      // Scaling about the centre moves a point inside / outside (F is homogeneous).
      const Eigen::Vector3d in = sq.position + 0.9 * (p - sq.position);
      const Eigen::Vector3d out = sq.position + 1.1 * (p - sq.position);
      EXPECT_LT(insideOutside(sq, in), 1.0);
      EXPECT_GT(insideOutside(sq, out), 1.0);
      EXPECT_NEAR(std::pow(insideOutside(sq, out), sq.e1 / 2.0), 1.1, 1e-9);
      EXPECT_NEAR(radialDistance(sq, out), 0.1 * (p - sq.position).norm(), 1e-9);
      EXPECT_NEAR(radialDistance(sq, in), 0.1 * (p - sq.position).norm(), 1e-9);
    }
    EXPECT_LT(insideOutside(sq, sq.position), 1e-6);
  }
}

TEST(Superquadric, KnownValuesOfEquationTwo) {
  // Axis-aligned at the origin: F(a1, 0, 0) = 1 and F(x, y, z) by hand for one point.
  const Superquadric sq = makeSq({1.0, 2.0, 3.0}, 0.5, 1.5);
  EXPECT_NEAR(insideOutside(sq, {1.0, 0.0, 0.0}), 1.0, 1e-9);
  EXPECT_NEAR(insideOutside(sq, {0.0, 2.0, 0.0}), 1.0, 1e-9);
  EXPECT_NEAR(insideOutside(sq, {0.0, 0.0, 3.0}), 1.0, 1e-9);
  const double x = 0.4, y = 0.6, z = 1.2;
  const double f =
      std::pow(std::pow(x / 1.0, 2.0 / 1.5) + std::pow(y / 2.0, 2.0 / 1.5), 1.5 / 0.5) +
      std::pow(z / 3.0, 2.0 / 0.5);
  EXPECT_NEAR(insideOutside(sq, {x, -y, -z}), f, 1e-12);
  // Eq. 3's residual at that point.
  EXPECT_NEAR(fitResidual(sq, {x, y, z}), std::sqrt(6.0) * (std::pow(f, 0.5) - 1.0), 1e-12);
}

TEST(Superquadric, GuardedPowersStayFinite) {
  const Superquadric sq = makeSq({0.2, 0.3, 0.4}, 0.1, 1.9, {0.3, 1.0, -0.4}, {1, 2, 3});
  const std::vector<Eigen::Vector3d> pts = {sq.position,
                                            toWorld(sq, {0.2, 0, 0}),
                                            toWorld(sq, {0, 0, -0.4}),
                                            toWorld(sq, {0, 1e-200, 0}),
                                            toWorld(sq, {1e6, -1e6, 1e6}),
                                            toWorld(sq, {0, 0, 1e100})};
  for (const auto& p : pts) {
    EXPECT_TRUE(std::isfinite(insideOutside(sq, p))) << p.transpose();
    EXPECT_TRUE(std::isfinite(logInsideOutside(sq, p)));
    EXPECT_TRUE(std::isfinite(fitResidual(sq, p)));
    EXPECT_TRUE(std::isfinite(radialDistance(sq, p)));
    EXPECT_TRUE(surfaceNormal(sq, p).allFinite());
  }
  EXPECT_NEAR(radialDistance(sq, toWorld(sq, {0, 0, -0.4})), 0.0, 1e-9);
  EXPECT_NEAR(radialDistance(sq, toWorld(sq, {0, 0, -1.0})), 0.6, 1e-9);
  // A point far away: distance ~ its norm, no overflow.
  EXPECT_NEAR(radialDistance(sq, toWorld(sq, {1e6, 0, 0})), 1e6 - 0.2, 1e-3);
}

TEST(Superquadric, VolumeMatchesAnalyticValues) {
  EXPECT_NEAR(volume(makeSq({0.5, 0.5, 0.5}, 1.0, 1.0)), 4.0 / 3.0 * kPi * 0.125, 1e-12);
  EXPECT_NEAR(volume(makeSq({0.5, 0.3, 0.2}, 1.0, 1.0)), 4.0 / 3.0 * kPi * 0.03, 1e-12);
  // Cylinder (e1 -> 0, e2 = 1): pi r^2 * 2 h.
  EXPECT_NEAR(volume(makeSq({0.2, 0.2, 0.5}, 1e-4, 1.0)), kPi * 0.04 * 1.0, 1e-4);
  // Box (e -> 0): 8 a1 a2 a3.
  EXPECT_NEAR(volume(makeSq({0.5, 0.3, 0.2}, 1e-4, 1e-4)), 8 * 0.03, 1e-4);
  // Octahedron (e1 = e2 = 2): 4/3 a1 a2 a3.
  EXPECT_NEAR(volume(makeSq({0.5, 0.3, 0.2}, 2.0, 2.0)), 4.0 / 3.0 * 0.03, 1e-12);
}

TEST(Superquadric, VolumeAgreesWithMonteCarloCount) {
  std::mt19937 rng(5);
  const Superquadric sq = makeSq({0.3, 0.2, 0.4}, 0.4, 1.4);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int inside = 0;
  const int n = 200000;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d p(0.3 * u(rng), 0.2 * u(rng), 0.4 * u(rng));
    inside += insideOutside(sq, p) < 1.0;
  }
  const double mc = 8 * 0.3 * 0.2 * 0.4 * inside / static_cast<double>(n);
  EXPECT_NEAR(volume(sq), mc, 0.01 * mc);
}

TEST(Superquadric, MeshIsClosedAndWoundOutward) {
  std::mt19937 rng(2);
  for (Superquadric sq : shapeFamily()) {
    samples::randomPose(sq, rng);
    const int res = 8;
    const TriangleMesh mesh = triangleMesh(sq, res);
    ASSERT_EQ(mesh.vertices.size(), static_cast<std::size_t>(6 * res * res + 2));
    ASSERT_EQ(mesh.triangles.size(), static_cast<std::size_t>(12 * res * res));
    // Closed 2-manifold: every directed edge appears once and its reverse once.
    std::map<std::pair<int, int>, int> edges;
    for (const auto& t : mesh.triangles) {
      for (int k = 0; k < 3; ++k) ++edges[{t[k], t[(k + 1) % 3]}];
    }
    for (const auto& e : edges) {
      EXPECT_EQ(e.second, 1);
      EXPECT_EQ(edges.count({e.first.second, e.first.first}), 1u);
    }
    // Euler characteristic of a sphere.
    EXPECT_EQ(static_cast<int>(mesh.vertices.size()) - static_cast<int>(edges.size() / 2) +
                  static_cast<int>(mesh.triangles.size()),
              2);
    for (const auto& v : mesh.vertices) EXPECT_NEAR(insideOutside(sq, v), 1.0, 1e-9);
    // Convex shapes (e <= 2): every normal points away from the centre; no degenerate
    // triangle.
    for (const auto& t : mesh.triangles) {
      const Eigen::Vector3d a = mesh.vertices[t[0]], b = mesh.vertices[t[1]],
                            c = mesh.vertices[t[2]];
      const Eigen::Vector3d n = (b - a).cross(c - a);
      EXPECT_GT(n.norm(), 1e-10);
      EXPECT_GT(n.dot((a + b + c) / 3.0 - sq.position), 0.0);
    }
  }
}

TEST(Superquadric, SampleSurfaceCountAndSpacing) {
  const Superquadric sq = makeSq({0.4, 0.4, 0.4}, 1.0, 1.0);
  const Points3d pts = sampleSurface(sq, 600);
  EXPECT_NEAR(static_cast<double>(pts.size()), 600.0, 120.0);
  // Nearest-neighbour spacing within a factor 2.5 between the sparsest and densest regions.
  double lo = 1e9, hi = 0.0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    double nn = 1e9;
    for (std::size_t j = 0; j < pts.size(); ++j) {
      if (i != j) nn = std::min(nn, (pts[i] - pts[j]).norm());
    }
    lo = std::min(lo, nn);
    hi = std::max(hi, nn);
  }
  EXPECT_LT(hi / lo, 2.5);
  EXPECT_THROW(sampleSurface(sq, 0), std::invalid_argument);
  EXPECT_THROW(triangleMesh(sq, 0), std::invalid_argument);
}

TEST(Superquadric, EulerZyzRoundTripIncludingGimbalLock) {
  std::mt19937 rng(3);
  std::vector<Eigen::Matrix3d> rotations;
  for (int i = 0; i < 200; ++i) {
    Superquadric sq;
    samples::randomPose(sq, rng);
    rotations.push_back(sq.rotation());
  }
  for (double theta : {0.0, 1e-12, kPi, kPi - 1e-12}) {
    for (double phi : {0.3, -2.0}) {
      Superquadric sq;
      sq.euler = Eigen::Vector3d(phi, theta, 0.7);
      rotations.push_back(sq.rotation());
    }
  }
  for (const auto& r : rotations) {
    Superquadric sq;
    sq.euler = eulerZyzFromRotation(r);
    EXPECT_TRUE(sq.euler.allFinite());
    EXPECT_LT((sq.rotation() - r).norm(), 1e-9);
    EXPECT_GE(sq.euler[1], 0.0);
    EXPECT_LE(sq.euler[1], kPi);
  }
}

TEST(Superquadric, SurfaceNormalOfSphereIsRadial) {
  const Superquadric sq = makeSq({0.5, 0.5, 0.5}, 1.0, 1.0, {0.1, 0.2, 0.3}, {1, 0, 0});
  for (const auto& p : sampleSurfaceRandom(sq, 50, 9u)) {
    EXPECT_LT((surfaceNormal(sq, p) - (p - sq.position).normalized()).norm(), 1e-9);
  }
}

TEST(Superquadric, SurfaceDistanceIsEuclideanToFirstOrder) {
  // Sphere: exact. Box face: a point 1 cm off a long face is 1 cm away, even near the end
  // of the face where the radial distance is inflated by the oblique ray.
  const Superquadric sphere = makeSq({0.5, 0.5, 0.5}, 1.0, 1.0, {0.3, 0.2, 0.1}, {1, 2, 3});
  EXPECT_NEAR(surfaceDistance(sphere, toWorld(sphere, {0.0, 0.6, 0.0})), 0.1, 1e-12);
  EXPECT_NEAR(surfaceDistance(sphere, toWorld(sphere, {0.3, 0.0, 0.0})), 0.2, 1e-12);
  const Superquadric slab = makeSq({0.1, 0.1, 0.5}, 0.3, 0.3);
  const Eigen::Vector3d p(0.11, 0.0, 0.3);  // 1 cm outside the x face, high up
  EXPECT_NEAR(surfaceDistance(slab, p), 0.01, 0.002);
  EXPECT_GT(radialDistance(slab, p), 0.025);
  EXPECT_TRUE(std::isfinite(surfaceDistance(slab, slab.position)));
  for (const auto& q : sampleSurfaceRandom(slab, 100, 4u))
    EXPECT_NEAR(surfaceDistance(slab, q), 0.0, 1e-9);
}
