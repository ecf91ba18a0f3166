// Speed work on shape retrieval, with known answers: the batched residual equals one residual
// per point, and its surface distances the scalar ones; results do not depend on the thread
// count (split and merge, shape retrieval, whole pipeline); the residual-noise split criterion
// keeps a laser-swept cylinder whole.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <memory>
#include <random>
#include <stdexcept>
#include <thread>

#include "../../src/common/parallel.h"
#include "novelty_detection/pipeline.h"
#include "novelty_detection/shape/shape_retrieval.h"
#include "novelty_detection/shape/split_merge.h"
#include "novelty_detection/shape/superquadric.h"
#include "novelty_detection/shape/superquadric_cost.h"
#include "novelty_detection/sim/scene.h"
#include "superquadric_samples.h"

using namespace novelty_detection;
using samples::makeSq;

namespace {

Points3d personPoints() {
  const Eigen::Vector3d sensor(-3.0, 0.4, 1.2);
  const std::vector<Superquadric> parts = {
      makeSq({0.18, 0.10, 0.28}, 0.3, 0.3, {0, 0, 0}, {0, 0, 1.2}),
      makeSq({0.09, 0.09, 0.11}, 1.0, 1.0, {0, 0, 0}, {0, 0, 1.6}),
      makeSq({0.06, 0.06, 0.42}, 0.2, 1.0, {0, 0, 0}, {0, -0.09, 0.45}),
      makeSq({0.06, 0.06, 0.42}, 0.2, 1.0, {0, 0, 0}, {0, 0.09, 0.45})};
  Points3d out;
  for (std::size_t k = 0; k < parts.size(); ++k) {
    for (const auto& p : samples::noisySamples(parts[k], 700, 0.004, 20u + k, &sensor)) {
      bool hidden = false;
      for (std::size_t m = 0; m < parts.size(); ++m)
        hidden = hidden || (m != k && insideOutside(parts[m], p) < 1.0);
      if (!hidden) out.push_back(p);
    }
  }
  return out;
}

/// The points of the one novelty of a simulated tilting-laser scene.
Points3d objectPoints(sim::NoveltyKind kind, std::uint64_t seed, double noise_variance_m2) {
  sim::SceneConfig cfg;
  cfg.seed = seed;
  cfg.novelty_kinds = {kind};
  cfg.laser.noise_variance_m2 = noise_variance_m2;
  const sim::ScenePair scene = sim::generateScenePair(cfg);
  Points3d out;
  if (scene.objects.empty()) return out;
  for (std::size_t i = 0; i < scene.current.size(); ++i) {
    if (scene.current_labels[i] != scene.objects.front().id) continue;
    const auto& p = scene.current[i];
    out.emplace_back(p.x, p.y, p.z);
  }
  return out;
}

/// Random points (within `extent` of the origin, one at the centre and one on an axis) and
/// superquadric parameters for a cost test; every fourth trial with a tiny rotation (both
/// branches of the rotation terms), and 37, 64 or 150 points (within one chunk, exactly one,
/// several with a partial last one).
struct CostCase {
  std::vector<Eigen::Vector3d> q;
  double a[3], e[2], w[3], t[3];
  const double* params[4] = {a, e, w, t};
  CostCase(std::mt19937& rng, int trial, double extent) {
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    q.resize(trial % 3 == 0 ? 37u : trial % 3 == 1 ? 64u : 150u);
    for (auto& p : q) p = extent * Eigen::Vector3d(u(rng), u(rng), u(rng));
    q[3].setZero();                         // the centre: guarded powers
    q[4] = Eigen::Vector3d(0.0, 0.0, 0.5);  // on an axis
    for (double& v : a) v = 0.3 + 0.2 * u(rng);
    for (double& v : e) v = 1.0 + 0.85 * u(rng);
    const double scale = trial % 4 == 0 ? 1e-6 : 1.5;
    for (double& v : w) v = scale * u(rng);
    for (double& v : t) v = 0.2 * u(rng);
  }
  CostCase(const CostCase&) = delete;
};

}  // namespace

TEST(SuperquadricCost, BatchResidualEqualsOneResidualPerPoint) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 21; ++trial) {
    const CostCase c(rng, trial, 1.0);
    const std::vector<Eigen::Vector3d>& q = c.q;
    const std::size_t n = q.size();
    const double *a = c.a, *e = c.e, *w = c.w, *t = c.t;
    const double* const* params = c.params;
    const SuperquadricBatchResidual batch(q);
    ASSERT_EQ(batch.num_residuals(), static_cast<int>(n));
    std::vector<double> r(q.size()), ja(3 * q.size()), je(2 * q.size()), jw(3 * q.size()),
        jt(3 * q.size());
    double* jac[4] = {ja.data(), je.data(), jw.data(), jt.data()};
    ASSERT_TRUE(batch.Evaluate(params, r.data(), jac));
    std::vector<double> r_only(q.size());
    ASSERT_TRUE(batch.Evaluate(params, r_only.data(), nullptr));
    // Terms are reused at the same parameters and recomputed at others (Ceres' order: the
    // cost at a candidate step, then the Jacobian there if accepted).
    double a2[3] = {a[0] * 1.1, a[1], a[2]};
    const double* other[4] = {a2, e, w, t};
    std::vector<double> r_other(q.size()), r_again(q.size()), ja2(ja.size());
    ASSERT_TRUE(batch.Evaluate(other, r_other.data(), nullptr));
    EXPECT_NE(r_other, r);
    double* jac2[4] = {ja2.data(), nullptr, nullptr, nullptr};
    ASSERT_TRUE(batch.Evaluate(params, r_again.data(), jac2));
    EXPECT_EQ(r_again, r);
    EXPECT_EQ(ja2, ja);
    const int sizes[4] = {3, 2, 3, 3};
    for (std::size_t i = 0; i < q.size(); ++i) {
      std::unique_ptr<ceres::CostFunction> one(SuperquadricAnalyticResidual::Create(q[i]));
      double r1, j1[4][3];
      double* jac1[4] = {j1[0], j1[1], j1[2], j1[3]};
      ASSERT_TRUE(one->Evaluate(params, &r1, jac1));
      const double tol = 1e-12 * (1.0 + std::abs(r1));
      EXPECT_NEAR(r[i], r1, tol) << "point " << i;
      EXPECT_EQ(r_only[i], r[i]);
      for (int b = 0; b < 4; ++b) {
        for (int c = 0; c < sizes[b]; ++c) {
          const double got = jac[b][sizes[b] * i + c];
          EXPECT_NEAR(got, j1[b][c], 1e-10 * (1.0 + std::abs(j1[b][c])))
              << "point " << i << " block " << b << " index " << c;
        }
      }
    }
  }
}

// The hinge on outside points: weight * max(0, -r) with its derivatives, r eq. 3's
// residual of the point (one residual per point), zero and flat outside the superquadric,
// whether the point lies inside the model's box or beyond it (those are skipped without
// eq. 3). Points in and around the model, some with a null Jacobian block asked.
TEST(SuperquadricCost, OutsideResidualIsTheHingeOfEq3) {
  std::mt19937 rng(11);
  int inside = 0, outside = 0;
  for (int trial = 0; trial < 21; ++trial) {
    const CostCase c(rng, trial, trial % 2 ? 0.5 : 1.5);
    const std::vector<Eigen::Vector3d>& q = c.q;
    const std::size_t n = q.size();
    const double weight = 0.5 + trial;
    const SuperquadricOutsideResidual hinge(q, weight);
    ASSERT_EQ(hinge.num_residuals(), static_cast<int>(n));
    const int sizes[4] = {3, 2, 3, 3};
    std::vector<double> r(n, -1.0), j[4];
    double* jac[4];
    for (int b = 0; b < 4; ++b) {
      j[b].assign(n * sizes[b], -1.0);  // every entry must be written
      jac[b] = trial % 5 == 4 && b == 1 ? nullptr : j[b].data();
    }
    ASSERT_TRUE(hinge.Evaluate(c.params, r.data(), jac));
    std::vector<double> r_only(n, -1.0);
    ASSERT_TRUE(hinge.Evaluate(c.params, r_only.data(), nullptr));
    for (std::size_t i = 0; i < n; ++i) {
      std::unique_ptr<ceres::CostFunction> one(SuperquadricAnalyticResidual::Create(q[i]));
      double r1, j1[4][3];
      double* jac1[4] = {j1[0], j1[1], j1[2], j1[3]};
      ASSERT_TRUE(one->Evaluate(c.params, &r1, jac1));
      const double scale = r1 < 0.0 ? -weight : 0.0;
      (r1 < 0.0 ? inside : outside)++;
      EXPECT_NEAR(r[i], scale * r1, 1e-12 * weight * (1.0 + std::abs(r1))) << "point " << i;
      EXPECT_GE(r[i], 0.0);
      EXPECT_EQ(r_only[i], r[i]);
      for (int b = 0; b < 4; ++b) {
        if (!jac[b]) continue;
        for (int k = 0; k < sizes[b]; ++k) {
          EXPECT_NEAR(j[b][sizes[b] * i + k], scale * j1[b][k],
                      1e-10 * weight * (1.0 + std::abs(j1[b][k])))
              << "point " << i << " block " << b << " index " << k;
        }
      }
    }
  }
  // Both sides were exercised.
  EXPECT_GT(inside, 50);
  EXPECT_GT(outside, 500);
  std::printf("outside residual: %d points inside the superquadrics, %d outside\n", inside,
              outside);
}

// With a surface weight the batched block appends each point's first-order surface
// distance, computed from eq. 3's terms: equal to the scalar SuperquadricSurfaceResidual
// (values and all Jacobian blocks), eq. 3's rows unchanged, at the centre and on an axis.
TEST(SuperquadricCost, BatchSurfaceDistancesEqualTheScalarResidual) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 21; ++trial) {
    const CostCase c(rng, trial, 0.6);
    const std::vector<Eigen::Vector3d>& q = c.q;
    const std::size_t n = q.size();
    const double* const* params = c.params;
    const double weight = 1.0 + 0.5 * u(rng);
    const SuperquadricBatchResidual plain(q), both(q, weight);
    const SuperquadricSurfaceResidual scalar(q, weight);
    ASSERT_EQ(both.num_residuals(), static_cast<int>(2 * n));
    const int sizes[4] = {3, 2, 3, 3};
    auto evaluate = [&](const ceres::CostFunction& f, std::vector<double>* r,
                        std::vector<double>(*j)[4], bool with_jacobians) {
      const std::size_t m = static_cast<std::size_t>(f.num_residuals());
      r->assign(m, 0.0);
      double* jac[4];
      for (int b = 0; b < 4; ++b) {
        (*j)[b].assign(m * sizes[b], 0.0);
        jac[b] = (*j)[b].data();
      }
      return f.Evaluate(params, r->data(), with_jacobians ? jac : nullptr);
    };
    std::vector<double> r_plain, r_both, r_scalar, r_only, jp[4], jb[4], js[4], jo[4];
    ASSERT_TRUE(evaluate(plain, &r_plain, &jp, true));
    ASSERT_TRUE(evaluate(both, &r_both, &jb, true));
    ASSERT_TRUE(evaluate(scalar, &r_scalar, &js, true));
    ASSERT_TRUE(evaluate(both, &r_only, &jo, false));
    for (std::size_t i = 0; i < n; ++i) {
      EXPECT_EQ(r_both[i], r_plain[i]) << "point " << i;
      EXPECT_NEAR(r_both[n + i], r_scalar[i], 1e-10 * (1.0 + std::abs(r_scalar[i])))
          << "point " << i << " trial " << trial;
      EXPECT_EQ(r_only[n + i], r_both[n + i]);
      for (int b = 0; b < 4; ++b) {
        for (int c = 0; c < sizes[b]; ++c) {
          EXPECT_EQ(jb[b][sizes[b] * i + c], jp[b][sizes[b] * i + c]);
          const double want = js[b][sizes[b] * i + c];
          EXPECT_NEAR(jb[b][sizes[b] * (n + i) + c], want, 1e-8 * (1.0 + std::abs(want)))
              << "point " << i << " block " << b << " index " << c << " trial " << trial;
        }
      }
    }
  }
}

// The solver's own layout: the same numbers as Ceres' row-major blocks, each parameter's
// column in place in a taller matrix (rows below and above it untouched), with and without
// the surface distances and when only the residuals are asked for.
TEST(SuperquadricCost, ColumnMajorEvaluationEqualsCeresBlocks) {
  std::mt19937 rng(13);
  for (int trial = 0; trial < 9; ++trial) {
    const CostCase c(rng, trial, 0.8);
    for (double weight : {0.0, 1.3}) {
      const SuperquadricBatchResidual batch(c.q, weight);
      const Eigen::Index m = batch.num_residuals(), above = 5, height = m + above + 7;
      const int sizes[4] = {3, 2, 3, 3}, starts[4] = {0, 3, 5, 8};
      std::vector<double> r(static_cast<std::size_t>(m)), blocks[4];
      double* jac[4];
      for (int b = 0; b < 4; ++b) {
        blocks[b].assign(static_cast<std::size_t>(m * sizes[b]), 0.0);
        jac[b] = blocks[b].data();
      }
      ASSERT_TRUE(batch.Evaluate(c.params, r.data(), jac));
      constexpr double kUntouched = -12345.0;
      Eigen::MatrixXd columns = Eigen::MatrixXd::Constant(height, 11, kUntouched);
      std::vector<double> r_columns(static_cast<std::size_t>(m)), r_only(r_columns);
      ASSERT_TRUE(
          batch.EvaluateColumnMajor(c.params, r_columns.data(), columns.data() + above, height));
      ASSERT_TRUE(batch.EvaluateColumnMajor(c.params, r_only.data(), nullptr, height));
      EXPECT_EQ(r_columns, r);
      EXPECT_EQ(r_only, r);
      for (int b = 0; b < 4; ++b) {
        for (int k = 0; k < sizes[b]; ++k) {
          for (Eigen::Index i = 0; i < m; ++i) {
            ASSERT_EQ(columns(above + i, starts[b] + k),
                      blocks[b][static_cast<std::size_t>(i * sizes[b] + k)])
                << "trial " << trial << " weight " << weight << " row " << i;
          }
        }
      }
      EXPECT_TRUE((columns.topRows(above).array() == kUntouched).all());
      EXPECT_TRUE((columns.bottomRows(height - above - m).array() == kUntouched).all());
    }
  }
}

TEST(ParallelFor, EveryItemOnceAndLowestExceptionRethrown) {
  for (int threads : {1, 2, 5}) {
    std::vector<int> hits(100, 0);
    detail::parallelFor(100, threads, [&](int i) { ++hits[static_cast<std::size_t>(i)]; });
    for (int h : hits) EXPECT_EQ(h, 1);
    std::atomic<int> ran{0};
    try {
      detail::parallelFor(10, threads, [&](int i) {
        ++ran;
        if (i == 3 || i == 7) throw std::runtime_error("item " + std::to_string(i));
      });
      ADD_FAILURE() << "no exception";
    } catch (const std::runtime_error& e) {
      EXPECT_STREQ(e.what(), "item 3");
    }
    EXPECT_EQ(ran.load(), 10);  // the other items still ran
  }
  // Nested loops run serially inside a worker and still visit every item.
  std::vector<int> inner(6, 0);
  detail::parallelFor(2, 2, [&](int i) {
    detail::parallelFor(3, 2, [&](int j) { ++inner[static_cast<std::size_t>(3 * i + j)]; });
  });
  for (int h : inner) EXPECT_EQ(h, 1);
}

// Loops started at the same time from several threads (two detectors in one process): one
// holds the pool, the others start their own threads; every item of every loop runs once.
TEST(ParallelFor, ConcurrentLoopsEachRunEveryItemOnce) {
  constexpr int kCallers = 3, kLoops = 200, kItems = 40;
  std::vector<std::vector<int>> hits(kCallers, std::vector<int>(kLoops * kItems, 0));
  std::vector<std::thread> callers;
  for (int c = 0; c < kCallers; ++c) {
    callers.emplace_back([&hits, c] {
      for (int loop = 0; loop < kLoops; ++loop) {
        detail::parallelFor(kItems, 3, [&](int i) {
          ++hits[static_cast<std::size_t>(c)][static_cast<std::size_t>(loop * kItems + i)];
        });
      }
    });
  }
  for (auto& t : callers) t.join();
  for (const auto& h : hits) {
    EXPECT_EQ(std::count(h.begin(), h.end(), 1), static_cast<long>(h.size()));
  }
}

TEST(SplitMerge, ResultDoesNotDependOnThreadCount) {
  const Points3d pts = personPoints();
  ASSERT_GT(pts.size(), 500u);
  SplitMerge one{SuperquadricParams()};
  one.setThreads(1);
  const auto ref = one.run(pts);
  ASSERT_GE(ref.size(), 2u);
  for (int threads : {2, 3}) {
    SplitMerge sm{SuperquadricParams()};
    sm.setThreads(threads);
    const auto got = sm.run(pts);
    ASSERT_EQ(got.size(), ref.size()) << threads << " threads";
    EXPECT_EQ(sm.stats().merge_fits, one.stats().merge_fits);
    for (std::size_t k = 0; k < ref.size(); ++k) {
      EXPECT_EQ(got[k].indices, ref[k].indices);
      EXPECT_EQ(got[k].fit.sq.a, ref[k].fit.sq.a);
      EXPECT_EQ(got[k].fit.sq.position, ref[k].fit.sq.position);
      EXPECT_EQ(got[k].fit.mean_distance, ref[k].fit.mean_distance);
    }
  }
}

TEST(ShapeRetrieval, ResultDoesNotDependOnThreadCount) {
  const Points3d pts = personPoints();
  ShapeRetrieval serial{SuperquadricParams()}, parallel{SuperquadricParams()};
  serial.setThreads(1);
  parallel.setThreads(2);
  const auto a = serial.recover(pts, subsample(pts, 200), 4);
  const auto b = parallel.recover(pts, subsample(pts, 200), 4);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].indices, b[k].indices);
    EXPECT_EQ(a[k].a, b[k].a);
    EXPECT_EQ(a[k].euler, b[k].euler);
    EXPECT_EQ(a[k].position, b[k].position);
    EXPECT_EQ(a[k].residual, b[k].residual);
  }
}

// New and disappeared segments' shapes are fitted as one list of jobs: the same on any
// number of threads, in segment order.
TEST(Pipeline, ResultDoesNotDependOnThreadCount) {
  sim::SceneConfig cfg;
  cfg.seed = 5;
  cfg.novelty_kinds = {sim::NoveltyKind::kPerson, sim::NoveltyKind::kBox,
                       sim::NoveltyKind::kRemovedObject};
  const sim::ScenePair s = sim::generateScenePair(cfg);
  Result results[3];
  for (int k = 0; k < 3; ++k) {
    Params p;
    p.compute.threads = k + 1;
    Pipeline pipeline(p);
    pipeline.setReference(s.reference);
    results[k] = pipeline.detect(s.current);
  }
  ASSERT_GE(results[0].disappeared_superquadrics.size(), 1u);
  // The wall behind the removed object is newly visible (classified in parallel blocks).
  EXPECT_GT(std::count(results[0].newly_visible.begin(), results[0].newly_visible.end(), 1), 50);
  for (int k = 1; k < 3; ++k) {
    ASSERT_EQ(results[0].disappeared_superquadrics.size(),
              results[k].disappeared_superquadrics.size());
    for (std::size_t j = 0; j < results[0].disappeared_superquadrics.size(); ++j) {
      const Superquadric &a = results[0].disappeared_superquadrics[j],
                         &b = results[k].disappeared_superquadrics[j];
      EXPECT_EQ(a.segment, b.segment);
      EXPECT_EQ(a.indices, b.indices);
      EXPECT_EQ(a.a, b.a);
      EXPECT_EQ(a.position, b.position);
    }
    EXPECT_EQ(results[0].labels, results[k].labels);
    EXPECT_EQ(results[0].superquadrics.size(), results[k].superquadrics.size());
    // The distances to the map (tau from their sample) are measured in parallel blocks.
    EXPECT_EQ(results[0].tau_m, results[k].tau_m);
    EXPECT_EQ(results[0].newly_visible, results[k].newly_visible);
    // The map's points the sweep saw through are classified in parallel blocks too.
    EXPECT_EQ(results[0].disappeared_labels, results[k].disappeared_labels);
  }
  EXPECT_EQ(results[0].labels, results[1].labels);
  ASSERT_EQ(results[0].superquadrics.size(), results[1].superquadrics.size());
  ASSERT_GE(results[0].segments.size(), 1u);
  ASSERT_GE(results[0].superquadrics.size(), 1u);
  for (std::size_t k = 0; k < results[0].superquadrics.size(); ++k) {
    const Superquadric &a = results[0].superquadrics[k], &b = results[1].superquadrics[k];
    EXPECT_EQ(a.segment, b.segment);
    EXPECT_EQ(a.indices, b.indices);
    EXPECT_EQ(a.a, b.a);
    EXPECT_EQ(a.position, b.position);
  }
}

TEST(ComputeParams, ThreadsResolveAndValidate) {
  ComputeParams c;
  EXPECT_GE(c.resolved(), 1);
  EXPECT_LE(c.resolved(), 8);
  c.threads = 3;
  EXPECT_EQ(c.resolved(), 3);
  c.threads = -1;
  EXPECT_THROW(c.validate(), std::invalid_argument);
}

// The split criterion compares a part's error with the noise seen in its own residuals: the
// scan lines of a tilting laser are each planar, so a local plane's RMS misses range noise
// and split a noisy cylinder into pieces; the residual noise keeps it whole.
TEST(SplitMerge, LaserSweptCylinderStaysOnePart) {
  for (std::uint64_t seed : {3u, 4u, 5u}) {
    const Points3d pts = objectPoints(sim::NoveltyKind::kCylinder, seed, 1e-4);  // sigma 1 cm
    ASSERT_GE(pts.size(), 100u) << "seed " << seed;
    const SplitMerge sm{SuperquadricParams()};
    const auto parts = sm.run(subsample(pts, SuperquadricParams().split_max_points));
    EXPECT_EQ(parts.size(), 1u) << "seed " << seed << " leaves " << sm.stats().leaves
                                << " plane noise " << sm.stats().plane_noise_m << " residual noise "
                                << sm.stats().residual_noise_m;
    // The residual noise is the range noise's normal component: 0.4..1.2 sigma.
    EXPECT_GT(sm.stats().residual_noise_m, 0.004) << "seed " << seed;
    EXPECT_LT(sm.stats().residual_noise_m, 0.012) << "seed " << seed;
  }
}
