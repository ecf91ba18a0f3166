// Known answers for the semi-real scene maker: a box ray-cast into a synthetic sweep of a
// wall cuts exactly the beams that pass through the box, onto its front face.
#include <gtest/gtest.h>

#include <cmath>

#include "novelty_detection/sim/semireal.h"

using namespace novelty_detection;

namespace {

/// Beams every 0.5 degrees (+-20 in azimuth and elevation) from the origin onto a wall at
/// x = 5.
Cloud wallSweep() {
  Cloud c;
  for (int a = -40; a <= 40; ++a)
    for (int e = -40; e <= 40; ++e) {
      const double az = a * 0.5 * M_PI / 180.0, el = e * 0.5 * M_PI / 180.0;
      const Eigen::Vector3d d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az),
                              std::sin(el));
      const Eigen::Vector3d p = d * (5.0 / d.x());
      c.push_back(PointT(p.x(), p.y(), p.z()));
    }
  setSensorOrigin(c, Eigen::Vector3f::Zero());
  return c;
}

}  // namespace

TEST(SemiRealInsertion, BoxCutsTheBeamsThroughItsFrontFace) {
  const Cloud scan = wallSweep();
  const sim::ObjectModel box = sim::boxModel({0.5, 0.6, 1.0}, 0.01);
  EXPECT_NEAR(box.height, 1.0, 1e-9);
  EXPECT_NEAR(box.radius, std::hypot(0.25, 0.3), 1e-6);
  const sim::Placement where{Eigen::Vector3d(3.0, 0.0, -0.5), 0.0};  // front face at x = 2.75
  const sim::Insertion in = sim::insertByRayCasting(scan, Eigen::Vector3f::Zero(), box, where);
  ASSERT_EQ(in.cloud.size(), scan.size());
  std::size_t expected = 0, edge = 0;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    // Where the beam meets the plane of the front face.
    const Eigen::Vector3d d = scan[i].getVector3fMap().cast<double>().normalized();
    const Eigen::Vector3d q = d * (2.75 / d.x());
    const double margin = std::max(std::abs(q.y()) - 0.3, std::abs(q.z()) - 0.5);
    if (std::abs(margin) < 0.02) {  // within the hit radius of the box's outline
      ++edge;
      continue;
    }
    const bool through = margin < 0.0;
    expected += through;
    EXPECT_EQ(in.truth[i], through ? 1 : 0) << i;
    if (through) {
      EXPECT_NEAR(in.cloud[i].x, 2.75, 0.02);
      EXPECT_NEAR((in.cloud[i].getVector3fMap().cast<double>().normalized() - d).norm(), 0.0, 1e-5);
    } else {
      EXPECT_EQ(in.cloud[i].getVector3fMap(), scan[i].getVector3fMap());
    }
  }
  EXPECT_GT(expected, 200u);
  EXPECT_LE(in.replaced, expected + edge);
  EXPECT_GE(in.replaced, expected);
}

TEST(SemiRealInsertion, PlacementsAreInSpaceTheBeamsCrossed) {
  const Cloud scan = wallSweep();
  const sim::ObjectModel box = sim::boxModel({0.4, 0.4, 0.5}, 0.01);
  const auto placements = sim::freeFloorPlacements(scan, Eigen::Vector3f::Zero(), scan, box, 3, 1);
  ASSERT_EQ(placements.size(), 3u);
  for (const sim::Placement& p : placements) {
    // In front of the wall, never in or behind it, and in the beams' cone.
    EXPECT_LT(p.base.x() + box.radius, 5.0);
    EXPECT_GT(p.base.x(), 1.0);
    EXPECT_LT(std::abs(p.base.y()), p.base.x() * std::tan(20.0 * M_PI / 180.0) + box.radius);
    EXPECT_GE(sim::insertByRayCasting(scan, Eigen::Vector3f::Zero(), box, p).replaced, 40u);
  }
  // Seeded: the same placements again.
  const auto again = sim::freeFloorPlacements(scan, Eigen::Vector3f::Zero(), scan, box, 3, 1);
  ASSERT_EQ(again.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) EXPECT_EQ(again[i].base, placements[i].base);
  EXPECT_THROW(sim::boxModel({0.0, 1.0, 1.0}), std::invalid_argument);
}
