// Changes over time: tracks of the novelties (or disappearances) of a stream of sweeps.
// ROS-free.
//
// A change that matters persists (a bag left behind); one that does not passes (a person
// walking by). ChangeTracker keeps a track per change: each sweep's segments are matched to
// the tracks, greedily by centroid distance, where a segment and a track match when their
// centroids are within tracking/gate_m or their bounding boxes overlap by at least
// tracking/min_overlap (intersection over union). A matched track takes the segment's
// centroid and box and counts one more sighting; an unmatched segment starts a track. A
// track is confirmed once seen in tracking/confirm_sweeps sweeps, and stays confirmed while
// it lives. A track is dropped after tracking/forget_sweeps sweeps in a row that covered its
// place (its centroid inside the sweep's extent) without detecting it; sweeps that did not
// look there leave it as it is, so a robot on patrol keeps what it saw behind it.
//
// Usage:
//   ChangeTracker tracker(params.tracking);
//   for each sweep: ids = tracker.update(result.segments, stamp_s, sweep_extent);
//                   tracker.track(ids[k])->confirmed ...
#pragma once

#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <vector>

#include "novelty_detection/params.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

struct ChangeTrack {
  std::uint32_t id = 0;  ///< > 0, kept while the change stays
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  Eigen::Vector3d bbox_min = Eigen::Vector3d::Zero();
  Eigen::Vector3d bbox_max = Eigen::Vector3d::Zero();
  double first_seen = 0.0;  ///< stamp of the first sweep that detected it [s]
  double last_seen = 0.0;   ///< stamp of the last one [s]
  int times_seen = 0;       ///< sweeps that detected it
  int missed = 0;           ///< sweeps in a row that covered its place without detecting it
  bool confirmed = false;   ///< times_seen reached tracking/confirm_sweeps
};

class ChangeTracker {
 public:
  /// Throws std::invalid_argument for invalid parameters.
  explicit ChangeTracker(const TrackingParams& params);

  /// The segments one sweep found (stamp in seconds, its usable extent in the same frame as
  /// the segments); returns the track id of each segment, in order. Stamps need not grow
  /// (a replayed bag), and a sweep with no segment only counts misses.
  std::vector<std::uint32_t> update(const std::vector<Segment>& segments, double stamp,
                                    const Eigen::AlignedBox3d& extent);
  /// The live track with this id, or nullptr.
  const ChangeTrack* track(std::uint32_t id) const;
  const std::vector<ChangeTrack>& tracks() const { return tracks_; }
  /// Tracks dropped since construction or reset (gone after fewer sightings than confirmation
  /// needs count in `transient_dropped`).
  std::size_t dropped() const { return dropped_; }
  std::size_t transientDropped() const { return transient_dropped_; }
  /// Forgets every track (a new reference map: the old changes are no longer changes).
  void reset();
  void setParams(const TrackingParams& params);

  /// At most this many tracks are kept; beyond it the one seen longest ago is dropped.
  static constexpr std::size_t kMaxTracks = 1000;

 private:
  bool matches(const ChangeTrack& t, const Segment& s, double* distance) const;

  TrackingParams params_;
  std::vector<ChangeTrack> tracks_;
  std::uint32_t next_id_ = 1;
  std::size_t dropped_ = 0, transient_dropped_ = 0;
};

/// Intersection over union of two axis-aligned boxes (0 when either is empty or they do not
/// meet; volumes of flat boxes are taken with a 1 cm floor per side).
double boxOverlap(const Eigen::Vector3d& a_min, const Eigen::Vector3d& a_max,
                  const Eigen::Vector3d& b_min, const Eigen::Vector3d& b_max);

}  // namespace novelty_detection
