// Parts of standing composite objects (shape/standing_parts.h): a person built from known
// superquadric parts and seen from the front is cut into its legs, arms, trunk and head;
// uniform columns and wide objects stay whole; simulated laser views of people at the
// paper's noise and at 1 cm get their parts through shape retrieval.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <random>
#include <set>

#include "novelty_detection/eval/shape_evaluation.h"
#include "novelty_detection/params.h"
#include "novelty_detection/shape/shape_retrieval.h"
#include "novelty_detection/shape/standing_parts.h"
#include "novelty_detection/shape/superquadric.h"
#include "novelty_detection/sim/scene.h"
#include "sim_objects.h"
#include "superquadric_samples.h"

using namespace novelty_detection;
using samples::makeSq;

namespace {

enum Group { kLeftLeg, kRightLeg, kLeftArm, kRightArm, kTrunk, kHead };

/// A standing person 1.75 m tall facing +x (the simulator's proportions, its narrowest
/// shoulders): feet and legs, arms hanging 1.5 cm beside the trunk, the head above a 4 cm
/// neck; each part's group.
std::vector<std::pair<Superquadric, Group>> personParts() {
  const double h = 1.75, foot_h = 0.08, leg_len = 0.47 * h - foot_h, torso_h = 0.30 * h;
  const double hip = foot_h + leg_len, torso_top = hip + torso_h, shoulder = 0.17;
  const double arm_len = 0.33 * h - 0.03;
  std::vector<std::pair<Superquadric, Group>> parts;
  for (const double side : {1.0, -1.0}) {
    const Group leg = side > 0 ? kLeftLeg : kRightLeg, arm = side > 0 ? kLeftArm : kRightArm;
    parts.push_back(
        {makeSq({0.13, 0.05, 0.5 * foot_h}, 0.1, 0.1, {0, 0, 0}, {0.04, side * 0.1, 0.5 * foot_h}),
         leg});
    parts.push_back({makeSq({0.075, 0.075, 0.5 * leg_len}, 0.4, 1.0, {0, 0, 0},
                            {0.0, side * 0.1, foot_h + 0.5 * leg_len}),
                     leg});
    parts.push_back({makeSq({0.05, 0.05, 0.5 * arm_len}, 0.4, 1.0, {0, 0, 0},
                            {0.0, side * (shoulder + 0.065), torso_top - 0.04 - 0.5 * arm_len}),
                     arm});
  }
  parts.push_back(
      {makeSq({0.12, shoulder, 0.5 * torso_h}, 0.5, 0.5, {0, 0, 0}, {0, 0, hip + 0.5 * torso_h}),
       kTrunk});
  parts.push_back(
      {makeSq({0.095, 0.08, 0.115}, 1.0, 1.0, {0, 0, 0}, {0, 0, torso_top + 0.04 + 0.115}), kHead});
  return parts;
}

/// Surface samples of `parts` facing `sensor` (about 10,000 per square metre of surface)
/// with Gaussian range noise sigma_m along the rays, and each point's group.
Points3d frontView(const std::vector<std::pair<Superquadric, Group>>& parts,
                   const Eigen::Vector3d& sensor, double sigma_m, std::vector<Group>* groups) {
  Points3d out;
  unsigned seed = 11u;
  std::mt19937 rng(7u);
  std::normal_distribution<double> noise(0.0, sigma_m > 0.0 ? sigma_m : 1.0);
  for (const auto& [sq, group] : parts) {
    const Eigen::Vector3d& a = sq.a;
    const double area = 4.0 * M_PI * (a.x() * a.y() + a.y() * a.z() + a.z() * a.x()) / 3.0;
    for (Eigen::Vector3d p :
         samples::noisySamples(sq, static_cast<int>(10000.0 * area), 0.0, seed++, &sensor)) {
      if (sigma_m > 0.0) p += noise(rng) * (p - sensor).normalized();
      out.push_back(p);
      groups->push_back(group);
    }
  }
  return out;
}

/// A standing box, cylinder or other solid's view from `sensor`.
Points3d viewOf(const Superquadric& sq, const Eigen::Vector3d& sensor) {
  std::vector<Group> groups;
  return frontView({{sq, kTrunk}}, sensor, 0.0, &groups);
}

}  // namespace

// The person seen from the front, noise-free and with 1 cm range noise: six parts, each of
// one body part, together all six. Limbs and head are pure (at least 90 % of their points);
// the trunk's band begins where the arms' lower ends widen the section, 6 cm below the hips,
// and holds the legs' tops and, with noise, the arms' inner edges (at least 65 % trunk;
// measured 70-75 %).
TEST(StandingParts, FrontViewOfAPersonGivesLegsArmsTrunkAndHead) {
  for (const double sigma : {0.0, 0.01}) {
    std::vector<Group> groups;
    const Points3d points = frontView(personParts(), {4.0, 0.3, 1.0}, sigma, &groups);
    const std::vector<Indices> parts = standingParts(points, Eigen::Vector3d::UnitZ(), 0.0, 12);
    ASSERT_EQ(parts.size(), 6u) << "sigma " << sigma;
    std::set<Group> found;
    std::size_t covered = 0;
    for (const auto& part : parts) {
      std::map<Group, int> count;
      for (int i : part) ++count[groups[static_cast<std::size_t>(i)]];
      const auto best = std::max_element(count.begin(), count.end(),
                                         [](auto& x, auto& y) { return x.second < y.second; });
      const double purity = best->first == kTrunk ? 0.65 : 0.9;

      EXPECT_GE(best->second, purity * static_cast<double>(part.size()))
          << "sigma " << sigma << " group " << best->first;
      found.insert(best->first);
      covered += part.size();
      EXPECT_TRUE(std::is_sorted(part.begin(), part.end()));
    }
    EXPECT_EQ(found.size(), 6u) << "sigma " << sigma;
    EXPECT_EQ(covered, points.size());
  }
}

// A section that does not step is one part: a tall box and a tall cylinder; an object not at
// least twice as tall as wide is not cut at all (a box on a narrower box, a ball).
TEST(StandingParts, ColumnsAndLowObjectsStayWhole) {
  const Eigen::Vector3d sensor(4.0, 1.0, 1.0), up = Eigen::Vector3d::UnitZ();
  const Points3d box = viewOf(makeSq({0.2, 0.25, 0.7}, 0.1, 0.1, {0.3, 0, 0}, {0, 0, 0.7}), sensor);
  const Points3d cylinder =
      viewOf(makeSq({0.15, 0.15, 0.6}, 0.1, 1.0, {0, 0, 0}, {0, 0, 0.6}), sensor);
  const Points3d ball = viewOf(makeSq({0.4, 0.4, 0.4}, 1.0, 1.0, {0, 0, 0}, {0, 0, 0.4}), sensor);
  Points3d stack = viewOf(makeSq({0.2, 0.2, 0.3}, 0.1, 0.1, {0, 0, 0}, {0, 0, 0.3}), sensor);
  const Points3d top = viewOf(makeSq({0.5, 0.5, 0.1}, 0.1, 0.1, {0, 0, 0}, {0, 0, 0.7}), sensor);
  stack.insert(stack.end(), top.begin(), top.end());
  for (const Points3d* points : std::vector<const Points3d*>{&box, &cylinder, &ball, &stack}) {
    ASSERT_GT(points->size(), 100u);
    const std::vector<Indices> parts = standingParts(*points, up, 0.0, 12);
    ASSERT_EQ(parts.size(), 1u);
    EXPECT_EQ(parts.front().size(), points->size());
  }
}

TEST(StandingParts, TooFewOrBadPointsGiveNothing) {
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  std::vector<Group> groups;
  Points3d points = frontView(personParts(), {4.0, 0.3, 1.0}, 0.0, &groups);
  EXPECT_TRUE(standingParts(Points3d(points.begin(), points.begin() + 23), up, 0.0, 12).empty());
  EXPECT_TRUE(standingParts(points, Eigen::Vector3d::Zero(), 0.0, 12).empty());
  EXPECT_TRUE(standingParts(points, up, 0.0, 0).empty());
  points[5].x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(standingParts(points, up, 0.0, 12).empty());
}

namespace {

struct PeopleTally {
  int people = 0;
  int three_to_seven = 0;  ///< fitted with 3 to 7 parts
  int upright = 0;         ///< the torso's part's long axis within 20 deg of up
  int both = 0;
};

/// Simulated people (scenes with one person, seeds 1..n, range noise variance `noise`) seen
/// by the tilting laser with at least 200 points, fitted as the detector fits them.
PeopleTally simulatedPeople(int n, double noise, bool standing) {
  PeopleTally t;
  SuperquadricParams params;
  params.standing_parts = standing;
  for (int seed = 1; seed <= n; ++seed) {
    sim::SceneConfig cfg;
    cfg.seed = static_cast<std::uint64_t>(seed);
    cfg.novelty_kinds = {sim::NoveltyKind::kPerson};
    cfg.laser.noise_variance_m2 = noise;
    const sim::ScenePair scene = sim::generateScenePair(cfg);
    if (scene.objects.empty()) continue;
    const auto& object = scene.objects.front();
    const Points3d fine = sim_objects::objectPoints(scene, object.id);
    if (fine.size() < 200) continue;
    const auto bounded = sim_objects::boundsOf(scene, cfg, object.id, fine, params);
    const std::vector<Superquadric> sqs = ShapeRetrieval(params).recover(
        fine, sim_objects::coarsePoints(fine), object.id, &bounded->bounds);
    ++t.people;
    const bool parts_ok = sqs.size() >= 3 && sqs.size() <= 7;
    std::vector<const Superquadric*> truth, fitted;
    for (const auto& part : object.parts) truth.push_back(&part.sq);
    for (const auto& sq : sqs) fitted.push_back(&sq);
    const Superquadric* main = mainFittedPart(fine, truth, fitted);
    int long_axis = 0;
    main->a.maxCoeff(&long_axis);
    const bool upright =
        std::abs(main->rotation().col(long_axis).z()) >= std::cos(20.0 * M_PI / 180.0);
    t.three_to_seven += parts_ok;
    t.upright += upright;
    t.both += parts_ok && upright;
  }
  return t;
}

}  // namespace

// The laser simulator's people (person-only scenes, seeds 1-30, those seen with at least 200
// points), at the paper's noise (sigma 3.2 cm) and at 1 cm, fitted within their bounds as
// the detector fits them: cut where their section steps, most get 3 to 7 parts and the part
// fitted to the torso upright (mainFittedPart(), as `evaluate` scores it); split and merge
// alone slices them across and gets far fewer.
TEST(StandingParts, SimulatedPeopleGetLegsTrunkAndHead) {
  for (const double noise : {0.001, 0.0001}) {
    const PeopleTally on = simulatedPeople(30, noise, true);
    const PeopleTally off = simulatedPeople(30, noise, false);
    std::printf(
        "noise %.4f: %d people; standing parts: 3-7 parts %d, upright %d, both %d; "
        "split and merge alone: %d, %d, %d\n",
        noise, on.people, on.three_to_seven, on.upright, on.both, off.three_to_seven, off.upright,
        off.both);
    ASSERT_GE(on.people, 12);  // 16 at either noise
    // Measured: 13 and 16 of 16 with 3 to 7 parts (3.2 cm, 1 cm); an upright trunk and 3
    // to 7 parts 12 and 15 of 16; split and merge alone (with the one-part test, which keeps
    // most sparse 3.2 cm views whole) 1 and 5.
    EXPECT_GE(on.three_to_seven, 0.8 * on.people);
    EXPECT_GE(on.both, 0.7 * on.people);
    EXPECT_GT(on.both, off.both + 3);
  }
}
