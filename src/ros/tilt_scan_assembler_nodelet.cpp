#include "novelty_detection/ros/tilt_scan_assembler_nodelet.h"
#include "novelty_detection/error_text.h"

#include <sensor_msgs/PointCloud2.h>
#include <tf2_eigen/tf2_eigen.h>
#include <pluginlib/class_list_macros.hpp>

#include <cmath>
#include <cstdint>
#include <exception>

#include "novelty_detection/ros/conversions.h"

namespace novelty_detection {
namespace {
constexpr double kWarnPeriodS = 5.0;
// A tilt step this many times the sweep's mean step is a fly-back, not a slow reversal.
constexpr double kFlyBackFactor = 5.0;

// Pitch of a rotation (Z-Y-X convention: rotation about the parent's y axis).
double pitchOf(const Eigen::Matrix3d& R) {
  return std::asin(std::max(-1.0, std::min(1.0, -R(2, 0))));
}
}  // namespace

TiltScanAssemblerNodelet::TiltScanAssemblerNodelet() = default;

TiltScanAssemblerNodelet::~TiltScanAssemblerNodelet() {
  tf_filter_.reset();
  scan_sub_.shutdown();
}

void TiltScanAssemblerNodelet::onInit() {
  ros::NodeHandle& nh = getNodeHandle();
  ros::NodeHandle& pnh = getPrivateNodeHandle();
  pnh.param("fixed_frame", fixed_frame_, fixed_frame_);
  pnh.param("tilt_parent_frame", tilt_parent_frame_, tilt_parent_frame_);
  pnh.param("max_sweep_duration", max_sweep_duration_, max_sweep_duration_);
  pnh.param("min_tilt_step_rad", min_tilt_step_rad_, min_tilt_step_rad_);
  pnh.param("min_lines", min_lines_, min_lines_);
  pnh.param("idle_timeout", idle_timeout_, idle_timeout_);
  pnh.param("queue_size", queue_size_, queue_size_);
  if (fixed_frame_.empty() || !(max_sweep_duration_ > 0.0) || min_lines_ < 1 ||
      !(min_tilt_step_rad_ >= 0.0) || !(idle_timeout_ > 0.0) || queue_size_ < 1) {
    NODELET_FATAL(
        "tilt scan assembler refuses to start: need a non-empty ~fixed_frame, "
        "~max_sweep_duration > 0, ~min_lines >= 1, ~min_tilt_step_rad >= 0, "
        "~idle_timeout > 0 and ~queue_size >= 1");
    return;
  }
  if (tilt_parent_frame_.empty()) tilt_parent_frame_ = fixed_frame_;

  tf_buffer_ = std::make_shared<tf2_ros::Buffer>();
  tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_, nh);
  sweep_pub_ = pnh.advertise<sensor_msgs::PointCloud2>("sweep", 2);
  tf_filter_ = std::make_unique<tf2_ros::MessageFilter<sensor_msgs::LaserScan>>(
      *tf_buffer_, fixed_frame_, static_cast<std::uint32_t>(queue_size_), nh);
  tf_filter_->registerCallback(&TiltScanAssemblerNodelet::onScan, this);
  tf_filter_->registerFailureCallback([this](const sensor_msgs::LaserScan::ConstPtr& scan,
                                             tf2_ros::filter_failure_reasons::FilterFailureReason) {
    NODELET_WARN_THROTTLE(kWarnPeriodS,
                          "scan line from frame '%s' dropped: no transform "
                          "to '%s'",
                          scan->header.frame_id.c_str(), fixed_frame_.c_str());
  });
  scan_sub_ = pnh.subscribe<sensor_msgs::LaserScan>(
      "scan", static_cast<std::uint32_t>(queue_size_),
      [this](const sensor_msgs::LaserScan::ConstPtr& scan) {
        {
          // A line has arrived when it is received: while it waits for its transform (tf
          // late on a loaded machine) the sweep it ends is not idle.
          std::lock_guard<std::mutex> lock(mutex_);
          last_line_wall_ = ros::WallTime::now();
        }
        tf_filter_->add(scan);  // may call onScan() at once, which takes the lock
      });
  idle_timer_ =
      pnh.createWallTimer(ros::WallDuration(idle_timeout_ / 4), [this](const ros::WallTimerEvent&) {
        std::lock_guard<std::mutex> lock(mutex_);
        // Fewer than ~min_lines lines are kept through a pause (a stalled process or player
        // whose next lines are still to come would otherwise lose the head of a sweep); the
        // stamps close them if the lines resume much later.
        const double idle = (ros::WallTime::now() - last_line_wall_).toSec();
        if (lines_ >= min_lines_ && idle > idle_timeout_) {
          NODELET_INFO("sweep closed after %.1f s without a line: %d lines, %zu points", idle,
                       lines_, sweep_.size());
          publishSweep("the idle timeout");
          have_pitch_ = false;
          direction_ = 0;
          typical_step_ = 0.0;
          steps_ = 0;
        }
      });
  NODELET_INFO("tilt scan assembler: %s -> %s in '%s'", scan_sub_.getTopic().c_str(),
               sweep_pub_.getTopic().c_str(), fixed_frame_.c_str());
}

void TiltScanAssemblerNodelet::publishSweep(const char* closed_by) {
  if (lines_ >= min_lines_ && !sweep_.empty()) {
    std_msgs::Header header;
    header.frame_id = fixed_frame_;
    header.stamp = last_stamp_;
    sweep_pub_.publish(toPointCloud2(sweep_, header));
    NODELET_DEBUG("sweep of %d lines, %zu points, closed by %s", lines_, sweep_.size(), closed_by);
  } else if (lines_ > 0) {
    // Lines are never lost without a word: a sweep this short is a laser started or stopped
    // mid-sweep, or lines out of order.
    NODELET_WARN_THROTTLE(kWarnPeriodS,
                          "%d line(s) (%zu points) not published: closed by %s with fewer "
                          "than ~min_lines (%d) lines",
                          lines_, sweep_.size(), closed_by, min_lines_);
  }
  sweep_.clear();
  lines_ = 0;
}

void TiltScanAssemblerNodelet::onScan(const sensor_msgs::LaserScan::ConstPtr& scan) {
  try {
    std::lock_guard<std::mutex> lock(mutex_);
    const ros::Time stamp = scan->header.stamp;
    const Eigen::Isometry3d T_fixed_laser = tf2::transformToEigen(
        tf_buffer_->lookupTransform(fixed_frame_, scan->header.frame_id, stamp));
    const Eigen::Isometry3d T_parent_laser =
        tilt_parent_frame_ == fixed_frame_ ? T_fixed_laser
                                           : tf2::transformToEigen(tf_buffer_->lookupTransform(
                                                 tilt_parent_frame_, scan->header.frame_id, stamp));

    // Close the sweep when the tilt reverses or it has lasted too long; time going
    // backwards (a bag restarting) also starts a new sweep.
    const double pitch = pitchOf(T_parent_laser.linear());
    const char* closed_by = nullptr;
    if (lines_ > 0 && stamp < last_stamp_) closed_by = "a stamp going back";
    if (lines_ > 0 && (stamp - sweep_start_).toSec() > max_sweep_duration_)
      closed_by = "~max_sweep_duration";
    if (have_pitch_) {
      const double step = pitch - last_pitch_;
      if (std::abs(step) > min_tilt_step_rad_) {
        const int dir = step > 0 ? 1 : -1;
        if (steps_ >= 2 && std::abs(step) > kFlyBackFactor * typical_step_) {
          // A fly-back: this line starts the next sweep, whose direction is not known yet.
          closed_by = "a fly-back";
          direction_ = 0;
          typical_step_ = 0.0;
          steps_ = 0;
        } else {
          if (direction_ != 0 && dir != direction_) closed_by = "a tilt reversal";
          direction_ = dir;
          typical_step_ = (typical_step_ * steps_ + std::abs(step)) / (steps_ + 1);
          ++steps_;
        }
      }
    }
    last_pitch_ = pitch;
    have_pitch_ = true;
    if (closed_by && direction_ != 0) {  // a reversal: the running step mean starts again
      typical_step_ = 0.0;
      steps_ = 0;
    }
    if (closed_by) publishSweep(closed_by);
    if (lines_ == 0) sweep_start_ = stamp;

    for (std::size_t i = 0; i < scan->ranges.size(); ++i) {
      const float r = scan->ranges[i];
      if (!std::isfinite(r) || r < scan->range_min || r > scan->range_max) continue;
      const double a = scan->angle_min + static_cast<double>(i) * scan->angle_increment;
      const Eigen::Vector3d p =
          T_fixed_laser * Eigen::Vector3d(r * std::cos(a), r * std::sin(a), 0);
      sweep_.push_back(
          PointT(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
    }
    ++lines_;
    last_stamp_ = stamp;
    last_line_wall_ = ros::WallTime::now();
  } catch (const std::exception& e) {
    NODELET_WARN_THROTTLE(kWarnPeriodS, "scan line skipped: %s", errorText(e).c_str());
  }
}

}  // namespace novelty_detection

PLUGINLIB_EXPORT_CLASS(novelty_detection::TiltScanAssemblerNodelet, nodelet::Nodelet)
