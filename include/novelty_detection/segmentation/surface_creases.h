// Concave creases: where two objects touch (a mug standing on a tin, a box pushed against
// another, a box lying against a wall) their surfaces meet in a valley as seen from the
// sensor. A connected piece of the sweep is split there into the objects it holds.
// ROS-free; PCL stays in the .cpp.
//
// Rule. With the sensor at o, a point p lies in a crease when the centroid c of the sweep's
// points within radius_m of p lies on the sensor's side of p by more than the noise allows:
//     (c - p) . n  >  k * sigma(|p - o|),
// n the normal of those points' best plane (smallest-eigenvalue eigenvector of their
// covariance) turned toward the sensor, sigma the sweep's range noise model
// (preprocess/range_noise.h) and k = crease_offset_factor. On a plane (c - p) . n is only
// p's own noise; at a convex edge (a box's corner) it is negative; at the bottom of a valley,
// where two faces rise toward the sensor on both sides of p, it is about radius_m / 4 for
// faces at right angles. Points with fewer than kMinCreaseNeighbours neighbours, or whose
// neighbours lie along a line (a single scan line: no plane), are never creases; nor are
// points seen edge-on (|n . (o - p)| below 0.2 of |o - p|), whose side of the plane the
// noise decides. Without a noise estimate (sigma 0) nothing is a crease. A coarse, noisy sweep
// (noise comparable to radius_m) shows no creases at all: the rule then changes nothing.
#pragma once

#include <Eigen/Core>

#include <functional>
#include <vector>

#include "novelty_detection/segmentation/novelty_segmentation.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

/// Neighbours (the point included) needed for a point to be tested.
constexpr int kMinCreaseNeighbours = 8;

/// The crease test over cloud[kept], answered per position in `kept` and cached (each point's
/// neighbourhood is only looked at when asked).
class CreaseTest {
 public:
  /// `index`: cloud[kept] in that order (outlives the test). `sigma_at(range)`: the noise
  /// standard deviation at a range from `origin`. `near_radius_m`: see nearCrease.
  CreaseTest(const Cloud& cloud, const Indices& kept, const NearestNeighbourIndex& index,
             const Eigen::Vector3f& origin, double radius_m, double offset_factor,
             std::function<double(double)> sigma_at, double near_radius_m = 0.0);
  /// Whether cloud[kept[position]] lies in a concave crease.
  bool inCrease(int position);
  /// Whether it or one of its neighbours within near_radius_m does (a crease sampled with
  /// gaps between its points still parts the surfaces on its two sides).
  bool nearCrease(int position);

  /// Answers nearCrease() (and inCrease() for the points it looks at) for `positions` ahead,
  /// on up to `threads` threads; each answer is a function of its position alone, so the
  /// later calls return what they would have computed. Nothing on one thread.
  void prepare(const std::vector<int>& positions, int threads);
  /// prepare() for the points of `segments` (cloud indices; those not in `kept` are skipped).
  void prepareSegments(const std::vector<Indices>& segments, int threads);

 private:
  const Cloud& cloud_;
  const Indices& kept_;
  const NearestNeighbourIndex& index_;
  Eigen::Vector3f origin_;
  double radius_, factor_, near_radius_;
  std::function<double(double)> sigma_at_;
  std::vector<signed char> state_;  ///< inCrease: -1 not tested, 0 no, 1 crease
  std::vector<signed char> near_;   ///< nearCrease: -1 not asked, 0 no, 1 yes
  std::vector<int> near_nn_;        ///< neighbour ids (scratch of nearCrease)

  /// inCrease()'s test itself (no cache).
  bool test(int position) const;
  /// nearCrease()'s answer from `near`, the position's neighbours within near_radius_ (none
  /// needed when it is in a crease itself), kept.
  bool settle(int position, const std::vector<int>& near);
};

}  // namespace novelty_detection
