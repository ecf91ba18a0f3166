// ROS shell around novelty_detection::Pipeline: sweeps in, novelties and markers out.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <nodelet/nodelet.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <ros/spinner.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/message_filter.h>
#include <tf2_ros/transform_listener.h>

#include <atomic>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "novelty_detection/Detect.h"
#include "novelty_detection/DetectorConfig.h"
#include "novelty_detection/SaveReference.h"
#include "novelty_detection/SetIgnoreRegions.h"
#include "novelty_detection/SetReference.h"
#include "novelty_detection/io/cloud_io.h"
#include "novelty_detection/params.h"
#include "novelty_detection/ros/node_params.h"
#include "novelty_detection/ros/sweep_gaps.h"
#include "novelty_detection/ros/tiled_reference.h"
#include "novelty_detection/tracking/change_tracker.h"

namespace novelty_detection {

/// Subscribes ~input (PointCloud2 sweeps), waits for their transform into ~fixed_frame,
/// hands the newest sweep to a worker thread (depth 1: a sweep arriving while one waits
/// replaces it and is counted as dropped) that compares it with the reference map and
/// publishes ~novelty_cloud, ~disappeared_cloud, ~labelled_cloud, ~superquadrics,
/// ~novelty_labels, ~gaussians (when ~display_gaussians) and ~novelties; novelties and
/// disappearances are tracked over the sweeps (tracking/*) and the confirmed ones published
/// on ~confirmed_novelties. The reference map is published on ~reference_cloud for display.
/// Services: ~capture_reference, ~set_reference, ~save_reference, ~detect,
/// ~set_ignore_regions, served on their own thread.
class NoveltyDetectorNodelet : public nodelet::Nodelet {
 public:
  NoveltyDetectorNodelet();
  ~NoveltyDetectorNodelet() override;

 private:
  static constexpr double kWarnPeriodS = 5.0;  // throttle period of repeated warnings
  // The sensor pose may be the latest tf has, this much older than the sweep (sensor_pose.h).
  static constexpr double kSensorPoseToleranceS = 0.5;

  void onInit() override;
  void publishStatus(const std::string& status);

  void onInput(const sensor_msgs::PointCloud2::ConstPtr& msg, const std::string& publisher);
  void onTransformable(const sensor_msgs::PointCloud2::ConstPtr& msg);
  void onTransformFailure(const sensor_msgs::PointCloud2::ConstPtr& msg,
                          tf2_ros::filter_failure_reasons::FilterFailureReason reason);
  void workerLoop();
  void processSweep(const sensor_msgs::PointCloud2::ConstPtr& msg);

  /// Converts a message to the fixed frame; throws with a clear message on bad data.
  Cloud toFixedFrame(const sensor_msgs::PointCloud2& msg, bool wait_for_transform) const;
  /// Runs detection (cloud in the fixed frame, sensed in `cloud_frame`) with the reference
  /// tiles around it; throws when impossible. `reference` (optional) gets the reference
  /// cloud the result's disappeared_labels refer to.
  Result detect(const Cloud& cloud, const std::string& cloud_frame, const ros::Time& stamp,
                Cloud* reference = nullptr) const;
  /// Sets cloud.sensor_origin_/orientation_ to the pose of ~sensor_frame (or of the sweep's
  /// frame when it is not the fixed frame) at `stamp`; leaves them when tf cannot tell.
  void setSensorPose(Cloud& cloud, const std::string& cloud_frame, const ros::Time& stamp) const;
  void loadReferenceFile(const std::string& path);
  /// Loads a reference file or directory (io/reference_sweeps.h) as the map; returns what
  /// was loaded. A file's sensor origin is preprocess/reference_origin if set, else
  /// (0, 0, 0) with preprocess/sensor_frame, else the file's viewpoint; a directory's are
  /// its sweeps' viewpoints. Throws what loadReference and TiledReference::setMap throw.
  std::string setReferenceFrom(const std::string& path);
  /// Publishes the map (thinned to ~reference_display_voxel_m) on ~reference_cloud, latched,
  /// when ~publish_reference is set.
  void publishReferenceDisplay(const Cloud& map);
  /// A reference file may hold what a sweep may: preprocess/max_points, checked on its header.
  LoadLimits referenceLimits() const;
  /// A copy of the parameters (live tuning may change them from another thread).
  Params currentParams() const;

  bool onCaptureReference(std_srvs::Trigger::Request& req, std_srvs::Trigger::Response& res);
  bool onSetReference(SetReference::Request& req, SetReference::Response& res);
  bool onSaveReference(SaveReference::Request& req, SaveReference::Response& res);
  bool onDetect(Detect::Request& req, Detect::Response& res);
  bool onSetIgnoreRegions(SetIgnoreRegions::Request& req, SetIgnoreRegions::Response& res);
  /// Tracks the result's novelties and disappearances (sweep extent from `cloud`, fixed
  /// frame) and fills their track fields in `array`.
  void trackChanges(const Result& result, const Cloud& cloud, double stamp, NoveltyArray& array);
  /// Forgets every track (a new reference).
  void resetTracks();
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat);
  /// dynamic_reconfigure (~tuning): applies the thresholds in config/Detector.cfg; an
  /// invalid combination is refused and the previous values are shown again.
  void onReconfigure(DetectorConfig& config, uint32_t level);
  /// Warns at most once per period per category, but at once when the text changes, so
  /// that different problems in a row are all reported.
  void warnThrottled(const std::string& category, const std::string& text);

  NodeParams node_params_;
  Params params_;
  std::string params_error_;                 // non-empty: refused to start
  std::vector<std::string> unknown_params_;  // under ~, read by nothing (warned about)

  std::shared_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  std::unique_ptr<tf2_ros::MessageFilter<sensor_msgs::PointCloud2>> tf_filter_;
  ros::Subscriber input_sub_;
  ros::Publisher status_pub_, novelty_cloud_pub_, disappeared_cloud_pub_, labelled_cloud_pub_,
      superquadrics_pub_, gaussians_pub_, novelties_pub_, confirmed_pub_, labels_pub_,
      reference_pub_;
  ros::ServiceServer capture_srv_, set_srv_, save_srv_, detect_srv_, ignore_srv_;
  ros::CallbackQueue service_queue_;  // the services' own, spun by service_spinner_
  std::unique_ptr<ros::AsyncSpinner> service_spinner_;
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  ros::WallTimer diagnostics_timer_;

  std::unique_ptr<TiledReference> reference_;
  // Changes over time (guarded by tracks_mutex_: the worker updates, services reset).
  std::mutex tracks_mutex_;
  std::unique_ptr<ChangeTracker> novelty_tracks_, disappearance_tracks_;

  boost::recursive_mutex reconfigure_mutex_;
  std::unique_ptr<dynamic_reconfigure::Server<DetectorConfig>> reconfigure_;
  mutable std::mutex params_mutex_;  // guards params_ after onInit

  // Depth-1 hand-over to the worker.
  std::mutex status_mutex_;      // orders "ready" and a reference file error on ~status
  bool init_done_ = false;       // "ready" published
  std::string reference_error_;  // ~reference_file could not be used
  std::mutex queue_mutex_;
  std::condition_variable queue_cv_;
  sensor_msgs::PointCloud2::ConstPtr pending_;
  bool stop_ = false;
  std::thread worker_;
  std::atomic<bool> capture_next_{false};

  // Statistics for diagnostics (guarded by stats_mutex_).
  mutable std::mutex stats_mutex_;
  std::size_t received_ = 0, processed_ = 0, dropped_ = 0, rejected_ = 0, failed_ = 0,
              tf_failures_ = 0, not_compared_ = 0;
  // Share of the last sweep near the map; false when that sweep could not be compared.
  double last_overlap_ = 0.0;
  bool last_compared_ = true;
  // Sweeps lost before reaching the node, from each publisher's header seq and stamps.
  std::map<std::string, SweepGaps> gaps_;
  std::size_t lost_upstream_ = 0;
  double last_processing_ms_ = 0.0, max_processing_ms_ = 0.0;
  std::string last_result_ = "none yet", last_error_;
  std::string last_alignment_ = "none yet";  // fine alignment of the last sweep
  std::map<std::string, std::pair<std::string, ros::WallTime>> last_warning_;
};

}  // namespace novelty_detection
