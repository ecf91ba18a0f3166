#include "novelty_detection/tracking/change_tracker.h"

#include <algorithm>
#include <limits>
#include <tuple>

namespace novelty_detection {

namespace {

constexpr double kMinSideM = 0.01;  // a flat box (a segment on one surface) still has volume

double volume(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  const Eigen::Vector3d side = (hi - lo).cwiseMax(kMinSideM);
  return side.prod();
}

}  // namespace

double boxOverlap(const Eigen::Vector3d& a_min, const Eigen::Vector3d& a_max,
                  const Eigen::Vector3d& b_min, const Eigen::Vector3d& b_max) {
  if ((a_min.array() > a_max.array()).any() || (b_min.array() > b_max.array()).any()) return 0.0;
  const Eigen::Vector3d lo = a_min.cwiseMax(b_min), hi = a_max.cwiseMin(b_max);
  if ((lo.array() > hi.array()).any()) return 0.0;
  const double inter = volume(lo, hi);
  const double uni = volume(a_min, a_max) + volume(b_min, b_max) - inter;
  return uni > 0.0 ? std::min(1.0, inter / uni) : 0.0;
}

ChangeTracker::ChangeTracker(const TrackingParams& params) { setParams(params); }

void ChangeTracker::setParams(const TrackingParams& params) {
  params.validate();
  params_ = params;
}

void ChangeTracker::reset() {
  tracks_.clear();
  dropped_ = transient_dropped_ = 0;
}

const ChangeTrack* ChangeTracker::track(std::uint32_t id) const {
  for (const ChangeTrack& t : tracks_)
    if (t.id == id) return &t;
  return nullptr;
}

bool ChangeTracker::matches(const ChangeTrack& t, const Segment& s, double* distance) const {
  *distance = (t.centroid - s.centroid).norm();
  if (*distance <= params_.gate_m) return true;
  return params_.min_overlap > 0.0 &&
         boxOverlap(t.bbox_min, t.bbox_max, s.bbox_min, s.bbox_max) >= params_.min_overlap;
}

std::vector<std::uint32_t> ChangeTracker::update(const std::vector<Segment>& segments, double stamp,
                                                 const Eigen::AlignedBox3d& extent) {
  // Candidate pairs, nearest first; each track and segment is used once.
  std::vector<std::tuple<double, std::size_t, std::size_t>> pairs;
  for (std::size_t s = 0; s < segments.size(); ++s) {
    for (std::size_t t = 0; t < tracks_.size(); ++t) {
      double d = 0.0;
      if (matches(tracks_[t], segments[s], &d)) pairs.emplace_back(d, s, t);
    }
  }
  std::sort(pairs.begin(), pairs.end());
  std::vector<std::uint32_t> ids(segments.size(), 0);
  std::vector<char> track_used(tracks_.size(), 0);
  for (const auto& [d, s, t] : pairs) {
    if (ids[s] != 0 || track_used[t]) continue;
    (void)d;
    track_used[t] = 1;
    ids[s] = tracks_[t].id;
  }
  // Tracks: seen again, missed, or out of view.
  std::vector<ChangeTrack> kept;
  kept.reserve(tracks_.size() + segments.size());
  for (std::size_t t = 0; t < tracks_.size(); ++t) {
    ChangeTrack track = tracks_[t];
    if (!track_used[t]) {
      if (extent.contains(track.centroid)) ++track.missed;
      if (track.missed >= params_.forget_sweeps) {
        ++dropped_;
        transient_dropped_ += !track.confirmed;
        continue;
      }
    }
    kept.push_back(track);
  }
  tracks_.swap(kept);
  for (std::size_t s = 0; s < segments.size(); ++s) {
    const Segment& seg = segments[s];
    ChangeTrack* track = nullptr;
    if (ids[s] != 0) {
      for (ChangeTrack& t : tracks_)
        if (t.id == ids[s]) track = &t;
    } else {
      ChangeTrack fresh;
      fresh.id = next_id_++;
      if (next_id_ == 0) next_id_ = 1;  // 4 billion changes later
      fresh.first_seen = stamp;
      tracks_.push_back(fresh);
      track = &tracks_.back();
      ids[s] = fresh.id;
    }
    track->centroid = seg.centroid;
    track->bbox_min = seg.bbox_min;
    track->bbox_max = seg.bbox_max;
    track->last_seen = stamp;
    track->missed = 0;
    ++track->times_seen;
    track->confirmed = track->confirmed || track->times_seen >= params_.confirm_sweeps;
  }
  // Bounded memory: the tracks seen longest ago go first.
  while (tracks_.size() > kMaxTracks) {
    auto oldest = std::min_element(
        tracks_.begin(), tracks_.end(),
        [](const ChangeTrack& a, const ChangeTrack& b) { return a.last_seen < b.last_seen; });
    ++dropped_;
    transient_dropped_ += !oldest->confirmed;
    tracks_.erase(oldest);
  }
  return ids;
}

}  // namespace novelty_detection
