// Sweeps lost before they reach the node (a full subscriber queue, a lossy link, a driver
// that skipped): counted from the headers of the sweeps that do arrive. ROS-free.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>

namespace novelty_detection {

/// Counts the sweeps missing between consecutive arrivals. When the source numbers its
/// messages (header.seq changes), a jump of seq by k > 1 means k - 1 lost sweeps. When it does
/// not (seq constant, as many roscpp drivers leave it), the stamps tell: once 4 intervals are
/// seen and the recent ones are regular (all within 0.5 to 1.5 times their median p), an
/// interval of more than 1.5 p counts round(interval / p) - 1 lost sweeps (an estimate for
/// periodic sources; an irregular source is not counted from stamps). A stamp or seq
/// going back (a bag replayed again, a restarted driver) starts over without counting.
class SweepGaps {
 public:
  /// The sweeps missing just before this one (0 for the first and after a restart).
  std::size_t observe(std::uint32_t seq, double stamp_s);
  /// The sum of what observe returned.
  std::size_t missing() const { return missing_; }

 private:
  static constexpr std::size_t kPeriods = 16, kMinPeriods = 4;
  static constexpr std::uint32_t kMaxSeqJump = 100000;  // larger: a new source, not a gap

  bool have_ = false;
  std::uint32_t last_seq_ = 0;
  double last_stamp_s_ = 0.0;
  std::deque<double> periods_;  // recent intervals without a gap
  std::size_t missing_ = 0;
};

}  // namespace novelty_detection
