// Continuations of novel segments into free space (ROS-free).
//
// ChoosePtfromGaussian (paper Sec. IV-D) keeps a point when the novel Gaussians hold most of
// its posterior. A Gaussian of the current mixture that spans part of a new object and the
// static structure it touches (a door leaf near its hinge and the wall there) is not
// selected, and the part of the object it owns is lost, although each of its points stands
// in space the reference saw as free, farther than tau from the map: the evidence of the
// distance and visibility rules without the posterior's. The rule: such points (`changed`)
// that are in no segment join the segment they are linked to (closer than the link radius,
// directly or through each other), breadth first from the segment's points, nearest links
// first, at most `max_growth` (kFreeMaxGrowth) times the segment's own points (the segment
// is the evidence for its continuation; a wall shifted by a pose error is no part of an
// object standing beside it). Points in no segment's reach stay as they are: without a
// selected Gaussian the rule makes no segment.
#pragma once

#include <functional>
#include <vector>

#include "novelty_detection/segmentation/novelty_segmentation.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

/// A segment's continuation holds at most this many times its own points.
constexpr double kFreeMaxGrowth = 1.0;

/// Grows `segments` (input indices of `cloud`) into the points of `kept` (ascending input
/// indices; `kept_index` indexes cloud[kept] in that order) for which `changed(index)` holds,
/// by the rule above. Each point is asked at most once; segments come back ascending.
/// Returns the number of points added.
std::size_t growIntoFreeSpace(const Cloud& cloud, const Indices& kept,
                              const NearestNeighbourIndex& kept_index,
                              std::vector<Indices>* segments, double link_radius_m,
                              double max_growth, const std::function<bool(int)>& changed);

}  // namespace novelty_detection
