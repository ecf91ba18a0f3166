// What an operator sees in rviz besides the raw results: a text label per change, the
// outline of each disappeared object, which Gaussians hold the novel points, and the
// reference map thinned for display.
#pragma once

#include <visualization_msgs/MarkerArray.h>

#include <Eigen/Core>

#include <string>
#include <vector>

#include "novelty_detection/NoveltyArray.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

/// The text shown above a change, e.g. "#3 new: 0.40 x 0.52 x 0.30 m, 252 pts" or
/// "#3 confirmed (seen 4): ..."; a disappearance reads "#2 gone: ..." (its box extents and
/// the reference points it held).
std::string noveltyLabel(const Novelty& novelty, bool disappeared);

/// DELETEALL, then per novelty a TEXT_VIEW_FACING marker (namespace "novelty_text", id =
/// its index), its letters a quarter of the box's largest extent high (5 to 18 cm), one
/// letter height above its box along `up` (the detector's up, Result::up; +z when not a
/// direction), in a light tint of its segment colour (segmentColour); per disappearance its
/// text one letter height below its box (namespace "disappeared_text", dark red) and the
/// outline of its box as a LINE_LIST (namespace "disappeared_box", 12 edges).
visualization_msgs::MarkerArray noveltyLabelMarkers(
    const NoveltyArray& array, const Eigen::Vector3d& up = Eigen::Vector3d::UnitZ());

/// Per Gaussian of result.current_gmm: true when the selection marked it novel and it is
/// the most likely component (weight times density) of at least one labelled point
/// (result.labels > 0) of `cloud`, the cloud the mixture was fitted to. A novel Gaussian
/// whose points the distance and visibility tests turned down is false.
std::vector<bool> gaussiansHoldingNovelPoints(const Result& result, const Cloud& cloud);

}  // namespace novelty_detection
