// Disappearances: reference structure the current sweep now sees through. ROS-free.
//
// Rule: with the current sensor origin o_c (current sensor_origin_, PCD VIEWPOINT or tf), a
// kept reference point q (pre-processed: no ground, no outlier) has disappeared when the current
// sweep's range image from o_c (visibility.h) classifies q as free: every current return around the
// ray o_c -> q lies farther than |q - o_c| + disappearance_margin_factor * tau, i.e. the
// current rays pass through space the reference saw occupied. The 3x3-cell neighbourhood of
// that test also keeps q away from every current point in front of it. Such points are
// linked into segments (linkComponents and the bounding-box merge of the novelty segments;
// smaller than visibility/min_disappeared_points are dropped) and described by superquadrics (Sec.
// V's ShapeRetrieval on the missing reference points). Without a current origin (zero) nothing is
// checked: the labels stay 0.
#pragma once

#include "novelty_detection/params.h"
#include "novelty_detection/shape/shape_retrieval.h"
#include "novelty_detection/types.h"
#include "novelty_detection/visibility/visibility.h"

namespace novelty_detection {

/// Fills result->disappeared_labels (reference.size(), always), disappeared_segments and,
/// when superquadric/enabled, disappeared_superquadrics. `candidates`: reference points
/// that may disappear. `tau_m`: the data's novelty distance. Returns false when skipped
/// (disabled, no current origin, empty input). `current_image`: the current sweep's range
/// image from its own origin with rangeImageConfig(params.visibility), when the caller has
/// built it already (built here otherwise).
bool findDisappearances(const Params& params, const Cloud& reference, const Indices& candidates,
                        const Cloud& current, double tau_m, Result* result,
                        const RangeImage* current_image = nullptr);

/// The superquadric part of findDisappearances: the shapes of each disappeared segment
/// (disappearedShapes), in segment order.
void fitDisappearedSuperquadrics(const SuperquadricParams& params, const Cloud& reference,
                                 Result* result);

/// The superquadrics of one disappeared segment of `reference` (indices into it); empty when
/// its fit fails. `retrieval` is not shared with another thread while this runs.
std::vector<Superquadric> disappearedShapes(const ShapeRetrieval& retrieval, const Cloud& reference,
                                            const Segment& segment);

}  // namespace novelty_detection
