// Parts of a standing composite object from its horizontal sections. ROS-free.
//
// Split and merge (split_merge.h) cuts a part across its main inertia axis while its fit is
// not explained within the noise. On a standing person seen by a tilting laser at a few cm
// of range noise that cuts the body into horizontal slabs (a shoulder slab, a hip slab),
// none of them a limb or the trunk: the noise hides the small surface errors that would
// tell a leg from a trunk. What does show is the body's horizontal section along up: two
// legs side by side, a trunk with the arms as wide as the shoulders, a narrow head. A tall
// object standing on the floor (its height at least kTallRatio times its width, the 5-95 %
// range of its points along its main horizontal axis) is therefore cut where its section
// changes:
//
//  - Layers: the points sorted by height above the floor, cut at vertical gaps of more
//    than kLayerGapFactor times their spacing (a tilting laser's lines) and at most
//    1 / kLayersPerHeight of the object's height thick; a layer of fewer than half the
//    median layer's points (a line split by the thickness bound: its width is not the
//    section's) joins the neighbour nearer in height, smallest first.
//  - Section width of a layer: the 5-95 % range of its points along the object's main
//    horizontal axis.
//  - Bands: the layer sequence is cut recursively where the points-weighted mean log width
//    changes by more than log(kSectionStep) both between the two sides and between the
//    layers within kWindowFraction of the height on either side of the cut (a step, not
//    the gradual change of a round object), each side keeping two layers and min_points;
//    of several such cuts the largest first.
//  - Limbs: in a band wider than the band below it by the step, the points beyond the
//    lower band's extent (its 2-98 % range, plus the link distance below) on either side
//    are a part of their own when they span at least kLimbSpan of the band's height (arms
//    beside a trunk over legs; the overhang of a table top is no taller than the top and
//    stays with it).
//  - Pieces: each band's points fall into the pieces their horizontal projections make,
//    linked at kLinkFactor times the point spacing (two legs side by side). Pieces of fewer
//    than min_points points or than kMinPieceShare of their band's join the part of their
//    nearest point.
//
// Each part is then fitted on its own (shape_retrieval.h). Seen from the side, a person's
// legs hide each other and their section is about as wide as the trunk's: the cut then
// finds the head at most.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "novelty_detection/types.h"

namespace novelty_detection {

constexpr double kTallRatio = 2.5;
constexpr double kSectionStep = 1.3;
constexpr int kLayersPerHeight = 16;
constexpr double kWindowFraction = 0.125;
constexpr double kLayerGapFactor = 1.5;
constexpr double kLinkFactor = 2.5;
constexpr double kLimbSpan = 0.5;
constexpr double kMinPieceShare = 0.1;

/// The parts (ascending indices into `points`, parts ordered by their lowest index) of
/// `points` standing on the floor up . p + floor_offset = 0 (`up` a unit normal), by the
/// rule of the header comment; a single part when the section does not change. Empty for
/// fewer than 2 * min_points points or a non-finite point.
std::vector<Indices> standingParts(const Points3d& points, const Eigen::Vector3d& up,
                                   double floor_offset, int min_points);

}  // namespace novelty_detection
