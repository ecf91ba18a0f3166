// Turning a core Result into ROS messages: NoveltyArray and rviz markers.
#pragma once

#include <std_msgs/Header.h>
#include <visualization_msgs/MarkerArray.h>

#include "novelty_detection/NoveltyArray.h"
#include "novelty_detection/tracking/change_tracker.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

/// One Superquadric message (pose from position + the ZYZ Euler rotation).
SuperquadricPart toSuperquadricMsg(const Superquadric& sq);

/// The NoveltyArray of a result: one Novelty per segment with its superquadrics; the
/// disappearances as Novelty entries of `disappeared` (points counted in the reference).
NoveltyArray toNoveltyArray(const Result& result, const std_msgs::Header& header,
                            double processing_time_s);

/// Fills track_id, times_seen, first_seen, last_seen and confirmed of each novelty and
/// disappearance from its track (entry i from tracks[i]; a null track leaves the entry
/// untracked).
void setTracks(NoveltyArray& array, const std::vector<const ChangeTrack*>& novelty_tracks,
               const std::vector<const ChangeTrack*>& disappeared_tracks);

/// The array with only its confirmed novelties and disappearances (everything else kept).
NoveltyArray confirmedOnly(const NoveltyArray& array);

/// A distinct, stable colour for a segment id (golden-ratio hue steps).
std_msgs::ColorRGBA segmentColour(int segment, float alpha = 0.8f);

/// DELETEALL, then one closed TRIANGLE_LIST mesh per superquadric (namespace
/// "superquadrics", id = its index), coloured by segment, and one per superquadric of a
/// disappearance (namespace "disappeared", translucent dark red).
visualization_msgs::MarkerArray superquadricMarkers(const Result& result,
                                                    const std_msgs::Header& header);

/// DELETEALL, then one SPHERE per Gaussian of the current mixture, at its mean, oriented
/// along its covariance's eigenvectors and scaled to its 2-sigma ellipsoid (diameter 4
/// sigma per axis); the `highlighted` ones (operator_display.h: the novel Gaussians that
/// hold labelled points) red in namespace "novel_gaussians", the others grey and
/// translucent in "gaussians".
visualization_msgs::MarkerArray gaussianMarkers(const Result& result,
                                                const std::vector<bool>& highlighted,
                                                const std_msgs::Header& header);

}  // namespace novelty_detection
