// One object, one part: a one-sided, noisy laser view of a single box, cylinder, sphere or
// superellipsoid is kept whole when its bounded fit explains it about as well as an exact fit
// would (SuperquadricParams::one_part_tolerance), instead of being cut by split and merge
// into pieces that each fit their few points closer. Simulated scenes with known shapes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "novelty_detection/params.h"
#include "novelty_detection/shape/fit_bounds.h"
#include "novelty_detection/shape/shape_retrieval.h"
#include "novelty_detection/shape/split_merge.h"
#include "novelty_detection/shape/superquadric.h"
#include "novelty_detection/sim/scene.h"
#include "sim_objects.h"
#include "superquadric_samples.h"

using namespace novelty_detection;
using samples::semiAxisError;

namespace {

struct Counts {
  int objects = 0;
  int one_part = 0;
  double semi_axis = 0.0;  ///< summed over the one-part fits [m]
  double distance = 0.0;   ///< mean point-to-surface distance, summed over all objects [m]
};

bool singleShape(sim::NoveltyKind kind) {
  return kind == sim::NoveltyKind::kBox || kind == sim::NoveltyKind::kCylinder ||
         kind == sim::NoveltyKind::kSphere || kind == sim::NoveltyKind::kSuperellipsoid;
}

/// Shape retrieval as the detector runs it (bounds from the sweep, the noise model estimated
/// from it) on the objects of `kinds` (all single shapes when empty) in simulated scenes of
/// seeds 1 to `seeds` with `novelties` objects each, corridors and offices in turn, at the
/// paper's range noise (sigma ~ 3.2 cm).
Counts retrieveAll(const SuperquadricParams& params, std::uint64_t seeds, int novelties,
                   const std::vector<sim::NoveltyKind>& kinds = {}) {
  Counts c;
  for (std::uint64_t seed = 1; seed <= seeds; ++seed) {
    sim::SceneConfig cfg;
    cfg.seed = seed;
    cfg.layout = seed % 2 ? sim::Layout::kCorridor : sim::Layout::kOffice;
    cfg.novelty_kinds = kinds;
    cfg.novelty_count = novelties;
    const sim::ScenePair scene = sim::generateScenePair(cfg);
    const RangeNoise noise = sim_objects::sweepNoise(scene);
    for (const auto& object : scene.objects) {
      if (kinds.empty() && !singleShape(object.kind)) continue;
      const Points3d fine = sim_objects::objectPoints(scene, object.id);
      if (fine.size() < 50) continue;
      const auto bounded = sim_objects::boundsOf(scene, cfg, object.id, fine, params, &noise);
      const auto sqs = ShapeRetrieval(params).recover(fine, sim_objects::coarsePoints(fine),
                                                      object.id, &bounded->bounds);
      ++c.objects;
      double sum = 0.0;
      for (const auto& sq : sqs) {
        for (int i : sq.indices) sum += surfaceDistance(sq, fine[static_cast<std::size_t>(i)]);
      }
      c.distance += sum / static_cast<double>(fine.size());
      if (sqs.size() == 1) {
        ++c.one_part;
        c.semi_axis += semiAxisError(sqs[0], object.parts.front().sq);
      }
    }
  }
  return c;
}

}  // namespace

// Scenes of three changes each (seeds 1-16): with the rule nearly every box, cylinder, sphere
// and superellipsoid is one part, sized about as well as the fewer one-part fits split and
// merge alone leaves, and its points lie within the noise of it (measured: 29 of 30 one part
// against 24, semi-axis error 23.9 mm against 23.1, point distance 19.8 mm against 18.5).
TEST(OnePartFits, OneSidedViewsOfOneShapeAreOnePart) {
  const SuperquadricParams params;
  SuperquadricParams split_only = params;
  split_only.one_part_tolerance = -1.0;
  const Counts with = retrieveAll(params, 16, 3);
  const Counts without = retrieveAll(split_only, 16, 3);
  ASSERT_GE(with.objects, 20);
  ASSERT_EQ(with.objects, without.objects);
  const double sigma = std::sqrt(sim::SceneConfig().laser.noise_variance_m2);
  std::printf(
      "one part %d / %d (split and merge alone %d), semi-axis error %.1f mm (%.1f), "
      "point distance %.1f mm (%.1f)\n",
      with.one_part, with.objects, without.one_part,
      1000 * with.semi_axis / std::max(1, with.one_part),
      1000 * without.semi_axis / std::max(1, without.one_part), 1000 * with.distance / with.objects,
      1000 * without.distance / without.objects);
  EXPECT_GT(with.one_part, without.one_part);
  EXPECT_GE(with.one_part, with.objects * 9 / 10);
  EXPECT_LT(with.semi_axis / with.one_part, 0.045);
  EXPECT_LT(with.distance / with.objects, 1.5 * sigma + 0.005);
}

// A person is not one shape: standing on the floor and deeper than a flat view, it is cut
// into legs, trunk and head before the one-part test is asked (seeds 1-10). Where that cut
// does not apply, a sparse view may pass the test (measured: 2 of 10 one part, 1 without it).
TEST(OnePartFits, APersonIsStillCutIntoParts) {
  SuperquadricParams split_only;
  split_only.one_part_tolerance = -1.0;
  const std::vector<sim::NoveltyKind> person = {sim::NoveltyKind::kPerson};
  const Counts with = retrieveAll(SuperquadricParams(), 10, 1, person);
  const Counts without = retrieveAll(split_only, 10, 1, person);
  ASSERT_GE(with.objects, 5);
  std::printf("people: one part %d / %d (split and merge alone %d)\n", with.one_part, with.objects,
              without.one_part);
  EXPECT_LE(with.one_part, without.one_part + 1);
  EXPECT_LE(with.one_part, with.objects / 5);
}

// The level split and merge calls exact is the noise in a fit's residuals: for points
// scattered normal to a box's surface with sigma s, (1 + t) sqrt(2 / pi) s (t the merge
// tolerance), whatever the points' spacing; a fit of the points' own shape within it is
// left whole by run().
TEST(OnePartFits, TheExactLevelIsTheNoiseInTheResiduals) {
  const SuperquadricParams params;
  const Superquadric box = samples::makeSq(Eigen::Vector3d(0.4, 0.3, 0.5), 0.1, 0.1);
  for (const double sigma : {0.005, 0.01, 0.02}) {
    std::mt19937 rng(17);
    std::normal_distribution<double> noise(0.0, sigma);
    Points3d points;
    for (const auto& p : sampleSurfaceRandom(box, 1200, 5u))
      points.push_back(p + noise(rng) * surfaceNormal(box, p));
    const SplitMerge split_merge(params);
    const double level = split_merge.exactLevel(points, box);
    const double expected =
        std::max(params.noise_factor, (1.0 + params.merge_tolerance) * std::sqrt(2.0 / M_PI)) *
        sigma;
    EXPECT_NEAR(level, expected, 0.25 * expected) << "sigma " << sigma;
    FitResult whole;
    whole.sq = box;
    EXPECT_EQ(split_merge.run(points, &whole).size(), 1u) << "sigma " << sigma;
  }
}

// Boxes standing on the floor, seen from anywhere (seeds 1-24, three boxes a scene, those
// seen with at least 150 points): an upright fit that ends with a section between an ellipse
// and a diamond has turned the wrong way from its start; it is refined again from the
// rectangle that diamond would be, and the lower objective wins. Measured: 15 one-part boxes,
// semi-axis error at most 30.5 mm, mean 16.7 mm; without the second start seed 17's box is
// fitted as a turned diamond 105 mm off (mean 21.6 mm).
TEST(OnePartFits, StandingBoxesAreNotFittedAsTurnedDiamonds) {
  const SuperquadricParams params;
  int one_part = 0;
  double semi_axis = 0.0, worst = 0.0;
  for (std::uint64_t seed = 1; seed <= 24; ++seed) {
    sim::SceneConfig cfg;
    cfg.seed = seed;
    cfg.layout = seed % 2 ? sim::Layout::kCorridor : sim::Layout::kOffice;
    cfg.novelty_kinds = {sim::NoveltyKind::kBox};
    cfg.novelty_count = 3;
    const sim::ScenePair scene = sim::generateScenePair(cfg);
    const RangeNoise noise = sim_objects::sweepNoise(scene);
    for (const auto& object : scene.objects) {
      const Points3d fine = sim_objects::objectPoints(scene, object.id);
      if (fine.size() < 150) continue;
      const auto bounded = sim_objects::boundsOf(scene, cfg, object.id, fine, params, &noise);
      const auto sqs = ShapeRetrieval(params).recover(fine, sim_objects::coarsePoints(fine),
                                                      object.id, &bounded->bounds);
      if (sqs.size() != 1) continue;
      ++one_part;
      const double error = semiAxisError(sqs[0], object.parts.front().sq);
      semi_axis += error;
      worst = std::max(worst, error);
      EXPECT_LT(error, 0.04) << "seed " << seed << " box " << object.id << ": " << fine.size()
                             << " points, e2 " << sqs[0].e2;
    }
  }
  std::printf("boxes with one part %d, semi-axis error mean %.1f mm, worst %.1f mm\n", one_part,
              1000.0 * semi_axis / std::max(1, one_part), 1000.0 * worst);
  ASSERT_GE(one_part, 12);
  EXPECT_LT(semi_axis / one_part, 0.02);
}
