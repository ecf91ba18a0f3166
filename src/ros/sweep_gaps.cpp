#include "novelty_detection/ros/sweep_gaps.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace novelty_detection {

std::size_t SweepGaps::observe(std::uint32_t seq, double stamp_s) {
  const bool restart = !have_ || !std::isfinite(stamp_s) || stamp_s <= last_stamp_s_ ||
                       (seq != last_seq_ && (seq < last_seq_ || seq - last_seq_ > kMaxSeqJump));
  std::size_t lost = 0;
  if (restart) {
    periods_.clear();
  } else {
    const double interval = stamp_s - last_stamp_s_;
    if (seq != last_seq_) {
      lost = seq - last_seq_ - 1;
    } else if (periods_.size() >= kMinPeriods) {
      std::vector<double> sorted(periods_.begin(), periods_.end());
      std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
      const double period = sorted[sorted.size() / 2];
      const auto [lo, hi] = std::minmax_element(sorted.begin(), sorted.end());
      const bool regular = *lo >= 0.5 * period && *hi <= 1.5 * period;
      if (regular && interval > 1.5 * period)
        lost = static_cast<std::size_t>(std::lround(interval / period)) - 1;
    }
    if (lost == 0) {
      periods_.push_back(interval);
      if (periods_.size() > kPeriods) periods_.pop_front();
    }
  }
  have_ = std::isfinite(stamp_s);
  last_seq_ = seq;
  last_stamp_s_ = stamp_s;
  missing_ += lost;
  return lost;
}

}  // namespace novelty_detection
