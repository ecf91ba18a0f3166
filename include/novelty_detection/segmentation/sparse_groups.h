// Compact groups among the points outlier removal took (ROS-free).
//
// Statistical outlier removal (Rusu et al. 2008) takes the points whose mean distance to their
// k nearest neighbours lies far above the sweep's: isolated returns, but also every point of a
// small object far from the sensor, sampled by a few scan lines at a spacing that the near
// surfaces dominating the statistic never have. Such an object is a change when it stands in
// space the reference saw through. The rule: the removed points that changed (`changed`:
// farther than the novelty distance from the map and in space the reference observed as free)
// are linked when closer than link_factor times the sweep's own spacing at their range (the
// range times spacingRatio(), the sensor's angular spacing as the kept points show it); a group
//  - that touches a segment (one of its points within that link distance of one of the
//    segment's) joins it: the sparse part of an object the segment found;
//  - else, of at least min_points points that spread in two directions (its second principal
//    spread at least kMinSpreadRatio of its first: a patch of surface, not a streak of mixed
//    returns along an edge), becomes a segment of its own.
// Isolated returns in free space stay removed: at the sweep's own spacing they have no
// neighbours.
//
// Free-standing groups: the same rule over the kept points that no segment holds. A far object
// whose points passed outlier removal but which no selected Gaussian owns (the Gaussians that
// hold it hold the structure around it too) is a change by the same evidence; such a group
// becomes a segment when it stands upright over several tilt lines (GroupShape::kStands: a far
// door leaf seen at a grazing angle is a narrow upright strip; a piece of one scan line that a
// pose error moved off a surface is not).
#pragma once

#include <Eigen/Core>

#include <functional>
#include <vector>

#include "novelty_detection/types.h"

namespace novelty_detection {

/// A group's second principal standard deviation must be at least this share of its first.
constexpr double kMinSpreadRatio = 0.2;
/// A group of kept points must stand: its vertical extent at least this many times the
/// sweep's spacing at its range (several tilt lines of an upright surface, a far door leaf
/// seen at a grazing angle; a piece of one scan line across a surface is no such group).
constexpr double kMinStandingSpacings = 4.0;

/// What makes a group that touches no segment a segment of its own (besides its size).
enum class GroupShape {
  kSpreadsInTwoDirections,  ///< the outliers' groups: a patch, not a streak along an edge
  kStands,                  ///< the kept points' groups: upright over several tilt lines
};

/// The median over `points` (input indices of `cloud`) of the distance to their k-th nearest
/// neighbour (`kth`, one per point) divided by their range from `origin`: the sweep's
/// neighbour spacing per metre of range. 0 when no point has a range.
double spacingRatio(const Cloud& cloud, const Indices& points, const std::vector<double>& kth,
                    const Eigen::Vector3f& origin);

struct SparseGroups {
  std::vector<Indices> joined;    ///< per segment given: the removed points that join it
  std::vector<Indices> segments;  ///< groups that are segments of their own
};

/// The groups of the rule above among `removed` (input indices of `cloud`), against the
/// segments `segments` (input indices). Every list comes back ascending, the new segments
/// largest first.
SparseGroups sparseNovelGroups(const Cloud& cloud, const Indices& removed,
                               const std::vector<Indices>& segments,
                               const std::function<bool(const Eigen::Vector3f&)>& changed,
                               const Eigen::Vector3f& origin, double spacing_ratio,
                               double link_factor, int min_points,
                               GroupShape shape = GroupShape::kSpreadsInTwoDirections);

}  // namespace novelty_detection
