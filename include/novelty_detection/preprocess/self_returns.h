// The robot's own returns (self-returns). ROS-free.
//
// A sensor on a robot sees parts of the robot (its body, mast, wheels) in every sweep, at
// the same place relative to the sensor. Comparing two sweeps taken from different poses,
// those returns are at different places in the map frame: the current ones look like a new
// object, the reference ones like a disappearance. The rule: within
// preprocess/self_max_range_m of its sensor, a point whose position in the sensor's frame
// (R_sensor^T (p - origin), from each cloud's sensor origin and orientation) lies within a
// tolerance of a point of the other sweep's sensor frame, and that has no point of the other
// sweep within the tolerance in the common (map) frame, is a self-return, in both sweeps:
// where the robot stood still, its returns and the scene around it match in both frames and
// nothing is marked; where it moved by less than the novelty distance, nothing is sought.
// The tolerance is twice the median spacing of the reference's near points (their sampling),
// so it scales with the sensor; spacings are measured between distinct samples (a cloud stored
// twice is the same sweep, and each repeat takes its first occurrence's mark). A part of the robot
// sampled sparsely and on other beams in the two sweeps (a bracket of a tilt mount) is matched
// within three times its own sampling spacing instead, when the map frame cannot explain it (no
// point of the other sweep within the novelty distance nor within twice that match). Static
// surfaces that run along the robot's motion (the floor under it, a corridor wall beside it) can
// match in the sensor frame too, where the other sweep sampled them more sparsely: they are
// unchanged, and dropping them loses nothing. A change beside the robot can match too: a
// surface that, in the sensor's frame, crosses one the other sweep saw there (a door leaf
// swung by about the robot's own step and turn) matches along the strip where the two meet.
// The robot lies within self_max_range_m of its sensor, and such a surface runs on past the
// strip as novel structure: a group of matched points that the map does not explain within
// the novelty distance, followed through the sweep's points that the map does not explain
// either (linked within twice the tolerance), that reaches to within that link of
// self_max_range_m at a point that did not match is no part of the robot, and none of it is
// marked (a group of at least segmentation/min_segment_points matched points: fewer are no
// strip of a surface to tell from a part of the robot that matched in part). Returns closer
// than preprocess/min_range_m are dropped as well (the laser_filters range filter). So are
// returns inside preprocess/body_box (a box in the sensor's frame, e.g. the base and mast below
// a tilting laser), in either sweep, moved or not. Both sensor origins must be known;
// otherwise nothing is marked.
#pragma once

#include <Eigen/Geometry>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "novelty_detection/params.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

struct SelfReturns {
  bool checked = false;  ///< both origins known and the filter on
  /// The sensor moved or turned about up by enough that the robot's returns were sought
  /// (else only min_range_m and body_box applied).
  bool sought = false;
  std::vector<std::uint8_t> current;    ///< per current point: 1 = self-return (or too close)
  std::vector<std::uint8_t> reference;  ///< per reference point: 1 = self-return (or too close)
  std::size_t current_count = 0, reference_count = 0;
  double tolerance_m = 0.0;
};

/// `novelty_distance_m`: when the sensor moved (plus its turn about up, z, times
/// self_max_range_m) by less than this, the robot's returns are within it of where they were
/// and are no change: only min_range_m applies. The clouds are in a frame whose z is up (the
/// pipeline's up frame); pitch and roll of the sensor (a tilting laser's head) do not count.
/// The box of preprocess/body_box: "" gives an empty box; six numbers with min <= max on
/// each axis give it; anything else throws std::invalid_argument naming the parameter.
Eigen::AlignedBox3f parseBodyBox(const std::string& text);

/// Angle [rad, 0..pi] by which the orientation `to` is turned about z from `from` (the twist
/// of the relative rotation): a pure pitch or roll gives 0.
double headingChange(const Eigen::Quaternionf& from, const Eigen::Quaternionf& to);

/// Whether the nearest point of a cloud lies within `radius` [m] (distance <= radius) of a
/// map-frame point; false when the cloud has none.
using NearestWithin = std::function<bool(const Eigen::Vector3f&, double radius)>;

/// The reference's side of the test, which depends on the map and the parameters alone: its
/// distinct points, its points within self_max_range_m of its sensor in the sensor's frame
/// with their index, those marks that need no other sweep (min_range_m, body_box) and the
/// tolerance. A map's model keeps it, so that the sweeps after the first that moved pay only
/// for their own side: it is made on first use (by any thread, once), from `reference`,
/// which must outlive it.
class SelfReturnReference {
 public:
  SelfReturnReference();
  /// Nothing is made unless the filter is on and the reference's origin is known.
  SelfReturnReference(const Cloud& reference, const PreprocessParams& params, int threads = 1);
  ~SelfReturnReference();
  SelfReturnReference(SelfReturnReference&&) noexcept;
  SelfReturnReference& operator=(SelfReturnReference&&) noexcept;

  struct Impl;
  /// The prepared side, made on the first call; null when nothing is to be made.
  const Impl* impl() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

/// `reference_within` and `current_within` (optional): that test against the finite points of
/// each cloud, when the caller keeps an index of them (a reference model, the current sweep's
/// pre-processing); else one is built here. They are called from up to `threads` threads at
/// once; the marks do not depend on the thread count. `prepared` (optional): the reference's
/// side made before from the same reference and parameters (the marks are the same).
/// `min_released`: a group of matched points that reaches out of the robot's range as novel
/// structure (header comment) is released when it holds at least this many of them (the
/// pipeline passes segmentation/min_segment_points); the release needs a novelty distance.
SelfReturns findSelfReturns(const Cloud& reference, const Cloud& current,
                            const PreprocessParams& params, double novelty_distance_m = 0.0,
                            const NearestWithin& reference_within = {},
                            const NearestWithin& current_within = {}, int threads = 1,
                            const SelfReturnReference* prepared = nullptr, int min_released = 1);

}  // namespace novelty_detection
