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
//
// Segments sampled more sparsely than the sweep: the link radius is link_factor times the
// median 4-NN spacing of the novel points, which the near, densely sampled surfaces set. A
// surface seen at a grazing angle (a door leaf swung nearly parallel to the beams) or far
// away is sampled at a larger spacing of its own, and the points of its next tilt line or
// of the next beams lie beyond that radius. Such a segment links at link_factor times its
// own points' median 4-NN spacing in the sweep (ownSpacingRadii), at most merge_gap_factor
// link radii (the farthest the segmentation merges the pieces of one object).
#pragma once

#include <functional>
#include <vector>

#include "novelty_detection/segmentation/novelty_segmentation.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

/// A segment's continuation holds at most this many times its own points.
constexpr double kFreeMaxGrowth = 1.0;

/// Per segment: link_factor times its sweepSpacing() in `kept_index` (over every
/// (size / kSpacingSamples)-th of its points), clamped to [link_radius_m, max_radius_m];
/// link_radius_m where the spacing is unknown.
std::vector<double> ownSpacingRadii(const Cloud& cloud, const std::vector<Indices>& segments,
                                    const NearestNeighbourIndex& kept_index, double link_factor,
                                    double link_radius_m, double max_radius_m);

/// A segment's own spacing is sampled at a stride of its size over this (all of a segment
/// of fewer points).
constexpr std::size_t kSpacingSamples = 256;

/// Grows `segments` (input indices of `cloud`) into the points of `kept` (ascending input
/// indices; `kept_index` indexes cloud[kept] in that order) for which `changed(index)` holds,
/// by the rule above. Each point is asked at most once; segments come back ascending.
/// Returns the number of points added. `radii`, when given, holds one link radius per
/// segment (each > 0) in place of `link_radius_m`.
std::size_t growIntoFreeSpace(const Cloud& cloud, const Indices& kept,
                              const NearestNeighbourIndex& kept_index,
                              std::vector<Indices>* segments, double link_radius_m,
                              double max_growth, const std::function<bool(int)>& changed,
                              const std::vector<double>* radii = nullptr);

}  // namespace novelty_detection
