// Continuations of novel segments across surfaces that turned (ROS-free).
//
// A door leaf that swung about its hinge lies, next to the hinge, within tau of where the old
// leaf stood: the distance test cannot tell those points from the map's, and the leaf's
// segment stops short of its hinge. Their surface runs another way than the map's there,
// though. The rule: a point within tau of the map whose neighbourhood in the sweep and whose
// neighbourhood in the map (the points within `radius` of it, ground and outliers left out)
// each run along one horizontal direction (line-like across the horizontal plane, see
// HorizontalDirection), sampled alike (kMaxSamplingRatio), with the two directions more than
// `min_angle_deg` apart lies on a surface that turned. Linked to a segment, it joins it
// (growIntoFreeSpace's growth, at most as many points as the segment has). The rule runs after
// object completion: the points it adds end a segment at its hinge and do not make it take the wall
// it meets there. Horizontal is the plane normal to z: the detector runs it in its up frame.
#pragma once

#include <cstddef>

#include <Eigen/Core>

#include "novelty_detection/segmentation/novelty_segmentation.h"

namespace novelty_detection {

/// A neighbourhood's direction across the horizontal plane is taken only when it is this
/// line-like: (l1 - l2) / (l1 + l2) of its horizontal covariance's eigenvalues. A vertical
/// surface sampled by a scan line or two gives 0.9-1 at the sweep's noise; a corner, a
/// post or a blob gives far less.
constexpr double kMinLineShare = 0.6;
/// Both neighbourhoods need this many points for a direction.
constexpr std::size_t kMinDirectionPoints = 4;
/// And neither may hold more than this many times the other's points: the sweep and the map
/// sampled the place alike. Where they did not (the map's sensor stood elsewhere, or saw part
/// of the place hidden), their directions describe different parts of it.
constexpr double kMaxSamplingRatio = 2.0;

/// The principal direction of a neighbourhood's points across the horizontal plane.
struct HorizontalDirection {
  double angle_rad = 0.0;   ///< in (-pi/2, pi/2]: a direction, not an orientation
  double line_share = 0.0;  ///< (l1 - l2) / (l1 + l2); 0 when the points do not spread
  std::size_t points = 0;
};
HorizontalDirection horizontalDirection(const NearestNeighbourIndex::Neighbourhood& n);

/// Angle [deg, 0..90] between two horizontal directions (modulo half a turn).
double directionAngleDeg(const HorizontalDirection& a, const HorizontalDirection& b);

/// Whether the surface about p turned by the rule above: the points of `sweep` and of `map`
/// within radius_m of p both give a direction, neither holds more than kMaxSamplingRatio times
/// the other's points, and the two directions are more than min_angle_deg apart.
/// (Whether p lies within tau of the map is the caller's test.)
bool surfaceTurned(const Eigen::Vector3f& p, const NearestNeighbourIndex& sweep,
                   const NearestNeighbourIndex& map, double radius_m, double min_angle_deg);

}  // namespace novelty_detection
