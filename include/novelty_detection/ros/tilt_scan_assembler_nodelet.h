// Assembles the LaserScan lines of a tilting laser into one PointCloud2 sweep.
#pragma once

#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/message_filter.h>
#include <tf2_ros/transform_listener.h>

#include <memory>
#include <mutex>
#include <string>

#include "novelty_detection/types.h"

namespace novelty_detection {

/// Subscribes ~scan (sensor_msgs/LaserScan), projects each line into ~fixed_frame with
/// the laser's pose from tf at the line's stamp, and publishes the accumulated lines on
/// ~sweep (PointCloud2, fixed frame) when the tilt direction reverses (the pitch of the
/// laser frame relative to ~tilt_parent_frame changes sign of motion) or when the sweep
/// lasts longer than ~max_sweep_duration seconds, or when no line arrived for ~idle_timeout
/// wall seconds (the laser stopped, or a bag ended) and it holds at least ~min_lines lines
/// (fewer wait for the lines after a pause). A step of the tilt several times the
/// sweep's typical step is a fly-back (a sawtooth tilt returning to its start): it closes
/// the sweep and the next sweep's direction is learnt afresh, so its first line is kept.
/// Up to ~queue_size lines wait for the callbacks or their transforms.
class TiltScanAssemblerNodelet : public nodelet::Nodelet {
 public:
  TiltScanAssemblerNodelet();
  ~TiltScanAssemblerNodelet() override;

 private:
  void onInit() override;
  void onScan(const sensor_msgs::LaserScan::ConstPtr& scan);
  /// Publishes the sweep (or says why its lines are not) and starts the next.
  void publishSweep(const char* closed_by);

  std::string fixed_frame_ = "map";
  std::string tilt_parent_frame_;     // "" = the fixed frame
  double max_sweep_duration_ = 10.0;  // [s]
  double min_tilt_step_rad_ = 1e-4;   // pitch changes below this are no motion
  int min_lines_ = 5;                 // shorter sweeps are not published
  double idle_timeout_ = 1.0;         // [s, wall] close the sweep when lines stop coming
  // Lines held while the callbacks are busy or their transforms are not in yet: a full
  // subscriber queue drops the oldest line without a word (about 25 s of a 40 Hz laser).
  int queue_size_ = 1000;

  std::shared_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  std::unique_ptr<tf2_ros::MessageFilter<sensor_msgs::LaserScan>> tf_filter_;
  ros::Subscriber scan_sub_;
  ros::Publisher sweep_pub_;
  ros::WallTimer idle_timer_;
  ros::WallTime last_line_wall_;

  std::mutex mutex_;
  Cloud sweep_;
  int lines_ = 0;
  ros::Time sweep_start_, last_stamp_;
  double last_pitch_ = 0.0;
  int direction_ = 0;          // +1 tilting up, -1 down, 0 unknown
  double typical_step_ = 0.0;  // running mean of |pitch step| in this sweep [rad]
  int steps_ = 0;              // steps in that mean
  bool have_pitch_ = false;
};

}  // namespace novelty_detection
