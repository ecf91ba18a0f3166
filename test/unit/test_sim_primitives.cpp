// Ray-primitive intersections against analytic distances.
#include <gtest/gtest.h>

#include <cmath>

#include "novelty_detection/sim/laser.h"
#include "novelty_detection/sim/primitives.h"
#include "novelty_detection/sim/random.h"
#include "novelty_detection/sim/world.h"

using namespace novelty_detection;
using namespace novelty_detection::sim;

namespace {
Ray ray(const Eigen::Vector3d& o, const Eigen::Vector3d& d) { return Ray{o, d.normalized()}; }
Eigen::Matrix3d rotZ(double a) { return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).matrix(); }
Eigen::Matrix3d rotY(double a) { return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY()).matrix(); }
Eigen::Vector3d randomUnit(Rng& rng) {
  Eigen::Vector3d v(standardNormal(rng), standardNormal(rng), standardNormal(rng));
  return v.normalized();
}
Superquadric makeSq(const Eigen::Vector3d& a, double e1, double e2, const Eigen::Vector3d& pos,
                    const Eigen::Vector3d& euler) {
  Superquadric s;
  s.a = a;
  s.e1 = e1;
  s.e2 = e2;
  s.position = pos;
  s.euler = euler;
  return s;
}
}  // namespace

TEST(SimPrimitives, PlaneHitObliqueParallelAndBehind) {
  Plane p(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0, 0, 2));
  EXPECT_NEAR(*p.intersect(ray({0, 0, 5}, {0, 0, -1})), 5.0, 1e-12);
  EXPECT_NEAR(*p.intersect(ray({0, 0, 2}, {1, 0, -1})), 2.0 * std::sqrt(2.0), 1e-12);
  EXPECT_FALSE(p.intersect(ray({0, 0, 2}, {1, 0, 0})));        // parallel
  EXPECT_FALSE(p.intersect(ray({0, 0, 2}, {0, 0, 1})));        // behind
  EXPECT_FALSE(p.intersect(ray({0, 0, 5}, {0, 0, -1}), 4.0));  // beyond t_max
}

TEST(SimPrimitives, QuadInsideAndOutsideItsBounds) {
  Quad q(Eigen::Vector3d(1, 0, 0), Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ(), 1.0, 2.0);
  EXPECT_NEAR(*q.intersect(ray({-2, 0.5, 1.5}, {1, 0, 0})), 3.0, 1e-12);
  EXPECT_NEAR(*q.intersect(ray({4, 0, 0}, {-1, 0, 0})), 3.0, 1e-12);  // two-sided
  EXPECT_FALSE(q.intersect(ray({-2, 1.2, 0}, {1, 0, 0})));
  EXPECT_FALSE(q.intersect(ray({-2, 0, 2.1}, {1, 0, 0})));
  // Oblique: from (-1, 0, 0) towards (1, 0.8, 0) -> length sqrt(4 + 0.64).
  EXPECT_NEAR(*q.intersect(ray({-1, 0, 0}, {2, 0.8, 0})), std::sqrt(4.64), 1e-12);
}

TEST(SimPrimitives, OrientedBoxFacesInsideAndMiss) {
  const Eigen::Matrix3d R = rotZ(0.5) * rotY(0.3);
  const Eigen::Vector3d c(1, 2, 3), half(0.5, 1.0, 1.5);
  OrientedBox b(c, R, half);
  for (int axis = 0; axis < 3; ++axis) {
    const Eigen::Vector3d n = R.col(axis);
    EXPECT_NEAR(*b.intersect(ray(c + 5.0 * n, -n)), 5.0 - half[axis], 1e-12);
    EXPECT_NEAR(*b.intersect(ray(c - 7.0 * n, n)), 7.0 - half[axis], 1e-12);
  }
  EXPECT_NEAR(*b.intersect(ray(c, R.col(1))), 1.0, 1e-12);  // from inside: exit face
  EXPECT_FALSE(b.intersect(ray(c + 5.0 * R.col(0) + 1.05 * R.col(1), -R.col(0))));
  EXPECT_THROW(OrientedBox(c, R, Eigen::Vector3d(0.1, 0.0, 0.1)), std::invalid_argument);
}

TEST(SimPrimitives, CylinderSideCapsRotatedAndMiss) {
  Cylinder c(Eigen::Vector3d(0, 0, 1), Eigen::Matrix3d::Identity(), 0.5, 1.0);
  EXPECT_NEAR(*c.intersect(ray({3, 0, 1.3}, {-1, 0, 0})), 2.5, 1e-12);    // side
  EXPECT_NEAR(*c.intersect(ray({0.2, 0.1, 5}, {0, 0, -1})), 3.0, 1e-12);  // top cap z = 2
  EXPECT_NEAR(*c.intersect(ray({0.2, 0.1, -4}, {0, 0, 1})), 4.0, 1e-12);  // bottom cap z = 0
  EXPECT_FALSE(c.intersect(ray({3, 0, 2.2}, {-1, 0, 0})));                // above
  EXPECT_FALSE(c.intersect(ray({3, 0.51, 1}, {-1, 0, 0})));               // beside
  // Side at an angle: from (2, 0, 1) towards the axis point at height 1.5.
  const Eigen::Vector3d d = Eigen::Vector3d(-2, 0, 0.5).normalized();
  EXPECT_NEAR(*c.intersect(ray({2, 0, 1}, d)), 1.5 / std::abs(d.x()), 1e-12);
  // Axis along x.
  Cylinder cx(Eigen::Vector3d::Zero(), rotY(M_PI / 2), 0.5, 1.0);
  EXPECT_NEAR(*cx.intersect(ray({0, 0, 3}, {0, 0, -1})), 2.5, 1e-12);
  EXPECT_NEAR(*cx.intersect(ray({3, 0.1, 0}, {-1, 0, 0})), 2.0, 1e-12);
}

TEST(SimPrimitives, SphereOutsideInsideTangentMiss) {
  Sphere s(Eigen::Vector3d(1, 1, 1), 0.5);
  EXPECT_NEAR(*s.intersect(ray({1, 1, 4}, {0, 0, -1})), 2.5, 1e-12);
  EXPECT_NEAR(*s.intersect(ray({1, 1, 1}, {0, 1, 0})), 0.5, 1e-12);
  // Off-centre by 0.3: chord half length 0.4.
  EXPECT_NEAR(*s.intersect(ray({1.3, 1, 4}, {0, 0, -1})), 3.0 - 0.4, 1e-12);
  EXPECT_FALSE(s.intersect(ray({1.51, 1, 4}, {0, 0, -1})));
  EXPECT_FALSE(s.intersect(ray({1, 1, 4}, {0, 0, 1})));
}

TEST(SimPrimitives, SuperellipsoidAxisRaysHitAtExactlyA) {
  const Eigen::Vector3d a(0.3, 0.5, 0.7), pos(1, 2, 3), euler(0.3, 0.5, -0.2);
  for (double e1 : {0.1, 0.5, 1.0, 1.5, 2.0})
    for (double e2 : {0.1, 0.5, 1.0, 1.5, 2.0}) {
      const Superquadric sq = makeSq(a, e1, e2, pos, euler);
      Superellipsoid se(sq);
      const Eigen::Matrix3d R = sq.rotation();
      for (int axis = 0; axis < 3; ++axis)
        for (double sign : {-1.0, 1.0}) {
          const Eigen::Vector3d n = sign * R.col(axis);
          const auto t = se.intersect(ray(pos + 4.0 * n, -n));
          ASSERT_TRUE(t) << "e1=" << e1 << " e2=" << e2 << " axis " << axis;
          EXPECT_NEAR(*t, 4.0 - a[axis], 1e-6) << "e1=" << e1 << " e2=" << e2;
        }
    }
}

TEST(SimPrimitives, SphericalSuperellipsoidEqualsSphere) {
  const Eigen::Vector3d c(0.5, -1.0, 0.8);
  const double r = 0.4;
  Superellipsoid se(makeSq(Eigen::Vector3d::Constant(r), 1.0, 1.0, c, {0.7, 1.1, 0.2}));
  Sphere s(c, r);
  Rng rng(11);
  int hits = 0, misses = 0;
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector3d o = c + 3.0 * randomUnit(rng);
    // Aim near the centre so about half the rays hit.
    const Eigen::Vector3d target = c + 0.6 * r * randomUnit(rng) * (1.0 + uniform01(rng));
    const Ray q = ray(o, target - o);
    const auto ts = s.intersect(q), te = se.intersect(q);
    ASSERT_EQ(bool(ts), bool(te)) << "ray " << i;
    if (ts) {
      EXPECT_NEAR(*te, *ts, 1e-6);
      ++hits;
    } else {
      ++misses;
    }
  }
  EXPECT_GT(hits, 100);
  EXPECT_GT(misses, 50);
}

TEST(SimPrimitives, EllipsoidMatchesAnalyticQuadratic) {
  const Eigen::Vector3d a(0.3, 0.5, 0.7), c(0, 0, 1);
  const Superquadric sq = makeSq(a, 1.0, 1.0, c, {0.4, 0.9, -0.6});
  Superellipsoid se(sq);
  const Eigen::Matrix3d R = sq.rotation();
  Rng rng(5);
  int hits = 0;
  for (int i = 0; i < 300; ++i) {
    const Eigen::Vector3d o = c + 2.5 * randomUnit(rng);
    const Eigen::Vector3d d = ((c + 0.5 * randomUnit(rng)) - o).normalized();
    // Scale space: |S (R^T (o - c) + t R^T d)|^2 = 1 with S = diag(1/a).
    const Eigen::Vector3d p = (R.transpose() * (o - c)).cwiseQuotient(a);
    const Eigen::Vector3d q = (R.transpose() * d).cwiseQuotient(a);
    const double A = q.squaredNorm(), B = p.dot(q), C = p.squaredNorm() - 1.0;
    const double disc = B * B - A * C;
    const auto t = se.intersect(Ray{o, d});
    if (disc < 1e-9 && disc > -1e-9) continue;  // grazing: either answer is fine
    ASSERT_EQ(disc > 0, bool(t)) << "ray " << i;
    if (t) {
      EXPECT_NEAR(*t, (-B - std::sqrt(disc)) / A, 1e-6);
      ++hits;
    }
  }
  EXPECT_GT(hits, 50);
}

TEST(SimPrimitives, BoxLikeSuperellipsoidIsCloseToTheBox) {
  const Eigen::Vector3d half(0.4, 0.3, 0.6), c(2, 0, 0.6);
  const Superquadric sq = makeSq(half, 0.1, 0.1, c, {0.3, 0.0, 0.0});
  Superellipsoid se(sq);
  OrientedBox box(c, sq.rotation(), half);
  Rng rng(3);
  for (int i = 0; i < 200; ++i) {
    // Rays from in front of a face towards a point in the middle half of that face: the box
    // is entered exactly there, and the superellipsoid's face is flat to ~1e-7 there.
    const int axis = i % 3;
    const double sign = (i / 3) % 2 ? 1.0 : -1.0;
    Eigen::Vector3d local(uniform(rng, -0.5, 0.5) * half.x(), uniform(rng, -0.5, 0.5) * half.y(),
                          uniform(rng, -0.5, 0.5) * half.z());
    local[axis] = sign * half[axis];
    Eigen::Vector3d away = 0.5 * randomUnit(rng);
    away[axis] = sign * 2.0;
    const Eigen::Vector3d target = c + sq.rotation() * local;
    const Eigen::Vector3d o = target + sq.rotation() * away;
    const Ray q = ray(o, target - o);
    const auto tb = box.intersect(q), ts = se.intersect(q);
    ASSERT_TRUE(tb && ts);
    EXPECT_NEAR(*tb, (target - o).norm(), 1e-9);
    EXPECT_NEAR(*ts, *tb, 1e-4);
  }
  // Superellipsoid points lie on F = 1.
  const auto t = se.intersect(ray({5, 0.1, 0.7}, {-1, 0, 0}));
  ASSERT_TRUE(t);
  EXPECT_NEAR(se.insideOutside(Eigen::Vector3d(5 - *t, 0.1, 0.7)), 1.0, 1e-6);
}

TEST(SimPrimitives, SuperellipsoidMissesAndInside) {
  const double r = 0.5;
  Superellipsoid se(makeSq(Eigen::Vector3d::Constant(r), 1.0, 1.0, {0, 0, 0}, {0, 0, 0}));
  // Through the bounding box corner region but outside the ball.
  EXPECT_FALSE(se.intersect(ray({0.42, 0.42, 3}, {0, 0, -1})));
  // Beside the bounding box.
  EXPECT_FALSE(se.intersect(ray({0.6, 0, 3}, {0, 0, -1})));
  // Pointing away.
  EXPECT_FALSE(se.intersect(ray({0, 0, 3}, {0, 0, 1})));
  // From inside: exit at the radius.
  EXPECT_NEAR(*se.intersect(ray({0, 0, 0}, {1, 1, 0})), r, 1e-6);
  EXPECT_THROW(Superellipsoid(makeSq({0.1, 0.1, 0.1}, 0.01, 1.0, {0, 0, 0}, {0, 0, 0})),
               std::invalid_argument);
  EXPECT_THROW(Superellipsoid(makeSq({0.1, -0.1, 0.1}, 1.0, 1.0, {0, 0, 0}, {0, 0, 0})),
               std::invalid_argument);
}

TEST(SimPrimitives, WorldReturnsNearestHitAndItsObject) {
  World w;
  w.add(std::make_shared<Plane>(Eigen::Vector3d(10, 0, 0), Eigen::Vector3d(-1, 0, 0), 0));
  w.add(std::make_shared<Sphere>(Eigen::Vector3d(5, 0, 0), 1.0, 7));
  w.add(std::make_shared<Sphere>(Eigen::Vector3d(3, 0, 0), 0.5, 4));
  const auto h = w.intersect(ray({0, 0, 0}, {1, 0, 0}));
  ASSERT_TRUE(h);
  EXPECT_NEAR(h->t, 2.5, 1e-12);
  EXPECT_EQ(h->object_id, 4);
  const auto h2 = w.intersect(ray({0, 0.8, 0}, {1, 0, 0}));
  ASSERT_TRUE(h2);
  EXPECT_EQ(h2->object_id, 7);
  EXPECT_NEAR(h2->t, 5.0 - 0.6, 1e-12);
  const auto h3 = w.intersect(ray({0, 3, 0}, {1, 0, 0}));
  ASSERT_TRUE(h3);
  EXPECT_EQ(h3->object_id, 0);
  EXPECT_FALSE(w.intersect(ray({0, 3, 0}, {1, 0, 0}), 9.0));
  EXPECT_FALSE(w.intersect(ray({0, 3, 0}, {-1, 0, 0})));
}

TEST(SimLaser, BeamGeometryMatchesTheHokuyo) {
  LaserConfig c;
  EXPECT_EQ(c.beamsPerLine(), 1081);
  EXPECT_NEAR(c.beamAngle(0), -135.0 * M_PI / 180.0, 1e-12);
  EXPECT_NEAR(c.beamAngle(1080), 135.0 * M_PI / 180.0, 1e-12);
  EXPECT_NEAR(c.tiltAt(0), c.tilt_min_deg * M_PI / 180.0, 1e-12);
  EXPECT_NEAR(c.tiltAt(c.lines - 1), c.tilt_max_deg * M_PI / 180.0, 1e-12);
  // Positive tilt looks down in front.
  EXPECT_LT(beamDirection(0.0, 0.3).z(), 0.0);
  EXPECT_NEAR(beamDirection(M_PI / 2, 0.3).z(), 0.0, 1e-12);
  c.lines = 0;
  EXPECT_THROW(c.validate(), std::invalid_argument);
}

TEST(SimLaser, RangeNoiseIsZeroMeanWithTheConfiguredVariance) {
  // The sensor inside a sphere of radius 5: every beam's true range is 5.
  World w;
  w.add(std::make_shared<Sphere>(Eigen::Vector3d(0, 0, 1), 5.0, 0));
  LaserConfig c;
  c.noise_variance_m2 = 0.001;
  const TiltScan s = simulateTiltScan(w, sensorPose(0, 0, 0, 1.0), c, 42);
  ASSERT_EQ(static_cast<int>(s.cloud.size()), c.lines * 1081);
  double sum = 0, sum2 = 0;
  for (const auto& p : s.cloud) {
    const double e = (p.getVector3fMap().cast<double>() - Eigen::Vector3d(0, 0, 1)).norm() - 5.0;
    sum += e;
    sum2 += e * e;
  }
  const double n = s.cloud.size(), mean = sum / n, var = sum2 / n - mean * mean;
  EXPECT_NEAR(mean, 0.0, 5 * std::sqrt(0.001 / n));
  EXPECT_NEAR(var, 0.001, 0.001 * 5 * std::sqrt(2.0 / n));
  // Deterministic for a seed, different for another.
  const TiltScan s2 = simulateTiltScan(w, sensorPose(0, 0, 0, 1.0), c, 42);
  const TiltScan s3 = simulateTiltScan(w, sensorPose(0, 0, 0, 1.0), c, 43);
  EXPECT_EQ(s.cloud[100].x, s2.cloud[100].x);
  EXPECT_NE(s.cloud[100].x, s3.cloud[100].x);
}
