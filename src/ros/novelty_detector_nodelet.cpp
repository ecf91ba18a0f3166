#include "novelty_detection/ros/novelty_detector_nodelet.h"
#include "novelty_detection/ros/reconfigure.h"

#include <std_msgs/String.h>
#include <tf2_eigen/tf2_eigen.h>
#include <visualization_msgs/MarkerArray.h>
#include <pluginlib/class_list_macros.hpp>

#include <chrono>
#include <cmath>
#include <exception>
#include <iomanip>
#include <limits>
#include <sstream>
#include <thread>

#include "novelty_detection/NoveltyArray.h"
#include "novelty_detection/alignment/alignment.h"
#include "novelty_detection/error_text.h"
#include "novelty_detection/io/cloud_io.h"
#include "novelty_detection/preprocess/input_check.h"
#include "novelty_detection/preprocess/sensor_origin.h"
#include "novelty_detection/process_memory.h"
#include "novelty_detection/ros/conversions.h"
#include "novelty_detection/ros/operator_display.h"
#include "novelty_detection/ros/result_messages.h"
#include "novelty_detection/ros/ros_params.h"

namespace novelty_detection {
namespace {

const char* reasonName(tf2_ros::filter_failure_reasons::FilterFailureReason reason) {
  switch (reason) {
    case tf2_ros::filter_failure_reasons::OutTheBack:
      return "the sweep is older than the transform buffer";
    case tf2_ros::filter_failure_reasons::EmptyFrameID:
      return "the sweep has an empty frame_id";
    default:
      return "no transform arrived before the queue overflowed";
  }
}

/// "~a, ~b" for the names a, b.
std::string joinNames(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "~" : ", ~") + n;
  return out;
}

}  // namespace

NoveltyDetectorNodelet::NoveltyDetectorNodelet() = default;

NoveltyDetectorNodelet::~NoveltyDetectorNodelet() {
  // Services run on their own thread: no call may start or run while the rest goes away.
  if (service_spinner_) service_spinner_->stop();
  capture_srv_.shutdown();
  set_srv_.shutdown();
  save_srv_.shutdown();
  detect_srv_.shutdown();
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    stop_ = true;
  }
  queue_cv_.notify_all();
  if (worker_.joinable()) worker_.join();
  // The filter calls back into this object: stop it before the rest goes away.
  tf_filter_.reset();
  input_sub_.shutdown();
}

void NoveltyDetectorNodelet::publishStatus(const std::string& status) {
  std_msgs::String msg;
  msg.data = status;
  status_pub_.publish(msg);
}

void NoveltyDetectorNodelet::onInit() {
  ros::NodeHandle& nh = getNodeHandle();
  ros::NodeHandle& pnh = getPrivateNodeHandle();
  status_pub_ = pnh.advertise<std_msgs::String>("status", 1, true);

  // Parameters: the same names as config/default.yaml (~group/name), defaults from the
  // core's structs; an invalid value refuses to start.
  try {
    params_ = loadRosParams(pnh);
    node_params_ = loadNodeParams(pnh);
    if (node_params_.keep_freed_buffers) keepFreedBuffers();
    unknown_params_ = unknownDetectorParams(pnh);
    if (!unknown_params_.empty() && pnh.param("strict_parameters", false))
      throw std::invalid_argument("unknown parameter(s) " + joinNames(unknown_params_) +
                                  " (~strict_parameters is set)");
    for (const std::string& name : unknown_params_)
      NODELET_WARN("parameter ~%s is not a parameter of the detector: ignored (misspelt?)",
                   name.c_str());
    novelty_tracks_ = std::make_unique<ChangeTracker>(params_.tracking);
    disappearance_tracks_ = std::make_unique<ChangeTracker>(params_.tracking);
    reference_ = std::make_unique<TiledReference>(
        params_, node_params_.tile_size_m, static_cast<std::size_t>(node_params_.tile_cache_size));
  } catch (const std::exception& e) {
    params_error_ = errorText(e);
    NODELET_FATAL("novelty detector refuses to start: %s", errorText(e).c_str());
    publishStatus(std::string("error: invalid parameters: ") + errorText(e));
    return;
  }

  tf_buffer_ = std::make_shared<tf2_ros::Buffer>();
  tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_, nh);

  novelty_cloud_pub_ = pnh.advertise<sensor_msgs::PointCloud2>("novelty_cloud", 1);
  disappeared_cloud_pub_ = pnh.advertise<sensor_msgs::PointCloud2>("disappeared_cloud", 1);
  labelled_cloud_pub_ = pnh.advertise<sensor_msgs::PointCloud2>("labelled_cloud", 1);
  superquadrics_pub_ = pnh.advertise<visualization_msgs::MarkerArray>("superquadrics", 1, true);
  labels_pub_ = pnh.advertise<visualization_msgs::MarkerArray>("novelty_labels", 1, true);
  if (node_params_.display_gaussians)
    gaussians_pub_ = pnh.advertise<visualization_msgs::MarkerArray>("gaussians", 1, true);
  reference_pub_ = pnh.advertise<sensor_msgs::PointCloud2>("reference_cloud", 1, true);
  novelties_pub_ = pnh.advertise<NoveltyArray>("novelties", 10);
  confirmed_pub_ = pnh.advertise<NoveltyArray>("confirmed_novelties", 10);

  // Services on their own queue and thread: a long set_reference or detect call never holds
  // up the input callbacks, the diagnostics timer or live tuning (calls are served in turn).
  ros::NodeHandle service_nh(pnh);
  service_nh.setCallbackQueue(&service_queue_);
  capture_srv_ = service_nh.advertiseService("capture_reference",
                                             &NoveltyDetectorNodelet::onCaptureReference, this);
  set_srv_ =
      service_nh.advertiseService("set_reference", &NoveltyDetectorNodelet::onSetReference, this);
  save_srv_ =
      service_nh.advertiseService("save_reference", &NoveltyDetectorNodelet::onSaveReference, this);
  detect_srv_ = service_nh.advertiseService("detect", &NoveltyDetectorNodelet::onDetect, this);
  ignore_srv_ = service_nh.advertiseService("set_ignore_regions",
                                            &NoveltyDetectorNodelet::onSetIgnoreRegions, this);
  service_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &service_queue_);
  service_spinner_->start();

  diagnostics_ = std::make_unique<diagnostic_updater::Updater>(nh, pnh, getName());
  diagnostics_->setHardwareID("none");
  diagnostics_->add("novelty detector", this, &NoveltyDetectorNodelet::diagnose);
  // The updater publishes once its own period (~diagnostic_period, 1 s) has passed since the
  // last message; asked at that same period it would find it not quite passed every other
  // time and publish every 2 s. Asked ten times as often, it publishes within 0.1 s of it.
  diagnostics_timer_ = pnh.createWallTimer(
      ros::WallDuration(0.1), [this](const ros::WallTimerEvent&) { diagnostics_->update(); });

  // Live tuning. The server reads its start values from the parameter server when it is
  // constructed and answers requests from then on, so the loaded values are put there
  // first: it never serves the .cfg defaults, not even for a moment.
  {
    const ros::NodeHandle tuning_nh(pnh, "tuning");
    DetectorConfig initial = DetectorConfig::__getDefault__();
    dynamic_reconfigure::Config msg;
    initial.__toMessage__(msg);
    paramsToConfigMsg(params_, msg);
    initial.__fromMessage__(msg);
    initial.__toServer__(tuning_nh);
    reconfigure_ = std::make_unique<dynamic_reconfigure::Server<DetectorConfig>>(reconfigure_mutex_,
                                                                                 tuning_nh);
  }
  reconfigure_->setCallback(
      [this](DetectorConfig& config, uint32_t level) { onReconfigure(config, level); });

  // The worker loads the reference file (possibly large) so that onInit never blocks.
  worker_ = std::thread(&NoveltyDetectorNodelet::workerLoop, this);

  tf_filter_ = std::make_unique<tf2_ros::MessageFilter<sensor_msgs::PointCloud2>>(
      *tf_buffer_, node_params_.fixed_frame, node_params_.input_queue_size, nh);
  tf_filter_->registerCallback(&NoveltyDetectorNodelet::onTransformable, this);
  tf_filter_->registerFailureCallback(
      [this](const sensor_msgs::PointCloud2::ConstPtr& msg,
             tf2_ros::filter_failure_reasons::FilterFailureReason reason) {
        onTransformFailure(msg, reason);
      });
  // A MessageEvent callback (named as such: a lambda would convert from the message pointer
  // and lose the connection header) tells which publisher sent each sweep.
  const boost::function<void(const ros::MessageEvent<const sensor_msgs::PointCloud2>&)> on_input =
      [this](const ros::MessageEvent<const sensor_msgs::PointCloud2>& event) {
        onInput(event.getConstMessage(), event.getPublisherName());
      };
  input_sub_ = pnh.subscribe<sensor_msgs::PointCloud2>("input", 2, on_input);

  {
    // The worker may already have failed on ~reference_file: its error follows "ready".
    std::lock_guard<std::mutex> lock(status_mutex_);
    publishStatus(unknown_params_.empty()
                      ? std::string("ready")
                      : "ready; unknown parameters ignored: " + joinNames(unknown_params_) +
                            " (~strict_parameters refuses them)");
    init_done_ = true;
    if (!reference_error_.empty()) publishStatus(reference_error_);
  }
  NODELET_INFO("novelty detector ready: fixed frame '%s', input %s",
               node_params_.fixed_frame.c_str(), input_sub_.getTopic().c_str());
}

void NoveltyDetectorNodelet::onInput(const sensor_msgs::PointCloud2::ConstPtr& msg,
                                     const std::string& publisher) {
  try {
    {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++received_;
      // Each publisher numbers its own messages: gaps are counted per publisher (a bounded
      // set: every rosbag play is a new one).
      if (gaps_.size() >= 64 && gaps_.count(publisher) == 0) gaps_.clear();
      const std::size_t lost = gaps_[publisher].observe(msg->header.seq, msg->header.stamp.toSec());
      lost_upstream_ += lost;
      if (lost > 0)
        NODELET_WARN_THROTTLE(kWarnPeriodS,
                              "%zu sweep(s) from %s lost before reaching the node (header seq "
                              "%u, stamp %.3f); %zu in all",
                              lost, publisher.c_str(), msg->header.seq, msg->header.stamp.toSec(),
                              lost_upstream_);
    }
    // The tf filter waits silently for frames that never come: say so at once.
    if (msg->header.frame_id.empty()) {
      warnThrottled("frame", "sweep has an empty frame_id; it is dropped");
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++rejected_;
      return;
    }
    if (!tf_buffer_->_frameExists(msg->header.frame_id)) {
      warnThrottled("frame", "sweep frame '" + msg->header.frame_id +
                                 "' is unknown to tf (yet); it waits for a transform to '" +
                                 node_params_.fixed_frame + "'");
    }
    tf_filter_->add(msg);
  } catch (const std::exception& e) {
    NODELET_ERROR_THROTTLE(kWarnPeriodS, "sweep refused: %s", errorText(e).c_str());
  }
}

void NoveltyDetectorNodelet::onTransformFailure(
    const sensor_msgs::PointCloud2::ConstPtr& msg,
    tf2_ros::filter_failure_reasons::FilterFailureReason reason) {
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++tf_failures_;
  }
  NODELET_WARN_THROTTLE(kWarnPeriodS, "sweep from frame '%s' at %.3f dropped: %s (to '%s')",
                        msg->header.frame_id.c_str(), msg->header.stamp.toSec(), reasonName(reason),
                        node_params_.fixed_frame.c_str());
}

void NoveltyDetectorNodelet::onTransformable(const sensor_msgs::PointCloud2::ConstPtr& msg) {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    if (pending_) {
      std::lock_guard<std::mutex> stats(stats_mutex_);
      ++dropped_;  // the newest sweep wins
    }
    pending_ = msg;
  }
  queue_cv_.notify_one();
}

void NoveltyDetectorNodelet::workerLoop() {
  if (!node_params_.reference_file.empty()) loadReferenceFile(node_params_.reference_file);
  while (true) {
    sensor_msgs::PointCloud2::ConstPtr msg;
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      queue_cv_.wait(lock, [this] { return stop_ || pending_; });
      if (stop_) return;
      msg.swap(pending_);
    }
    try {
      processSweep(msg);
    } catch (...) {  // processSweep catches std::exception; never let the thread die
      NODELET_ERROR("unexpected non-standard exception while processing a sweep");
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++failed_;
    }
  }
}

void NoveltyDetectorNodelet::processSweep(const sensor_msgs::PointCloud2::ConstPtr& msg) {
  const auto t0 = std::chrono::steady_clock::now();
  Cloud cloud;
  try {
    cloud = toFixedFrame(*msg, false);
    std::size_t finite = 0;
    for (const auto& p : cloud) {
      finite += std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
    }
    if (finite == 0) {
      throw std::invalid_argument(cloud.empty()
                                      ? "the sweep is empty"
                                      : "the sweep has no finite point (" +
                                            std::to_string(cloud.size()) + " points, all NaN/inf)");
    }
  } catch (const std::exception& e) {
    warnThrottled("rejected", std::string("sweep rejected: ") + errorText(e));
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++rejected_;
    last_error_ = errorText(e);
    return;
  }

  std_msgs::Header header = msg->header;
  header.frame_id = node_params_.fixed_frame;
  // The sensor pose: the reference's viewpoint when captured (free-space check), the
  // current viewpoint otherwise (disappearances).
  setSensorPose(cloud, msg->header.frame_id, msg->header.stamp);
  if (capture_next_.exchange(false)) {
    try {
      if (!sensorOriginKnown(cloud.sensor_origin_))
        NODELET_WARN(
            "captured reference without a viewpoint (the sweep is in the fixed frame "
            "and ~sensor_frame is not set)");
      reference_->setMap(cloud);
      resetTracks();
      publishReferenceDisplay(cloud);
      NODELET_INFO("captured the sweep at %.3f as the reference (%zu points)", header.stamp.toSec(),
                   cloud.size());
    } catch (const std::exception& e) {
      NODELET_ERROR("capturing the reference failed: %s", errorText(e).c_str());
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++failed_;
      last_error_ = errorText(e);
    }
    return;
  }
  if (!reference_->hasMap()) {
    NODELET_WARN_THROTTLE(kWarnPeriodS,
                          "no reference map yet: set ~reference_file or call "
                          "~capture_reference / ~set_reference");
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++rejected_;
    last_error_ = "no reference map";
    return;
  }

  try {
    Cloud reference;
    const Result result = detect(cloud, msg->header.frame_id, msg->header.stamp, &reference);
    // Outputs are in the map frame after the fine alignment's correction.
    if (result.alignment.applied) cloud = transformCloud(cloud, result.alignment.correction);
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    NoveltyArray array = toNoveltyArray(result, header, ms / 1000.0);
    trackChanges(result, cloud, header.stamp.toSec(), array);
    novelties_pub_.publish(array);
    confirmed_pub_.publish(confirmedOnly(array));
    novelty_cloud_pub_.publish(toLabelledPointCloud2(cloud, result.labels, header, true));
    disappeared_cloud_pub_.publish(
        toLabelledPointCloud2(reference, result.disappeared_labels, header, true));
    if (labelled_cloud_pub_.getNumSubscribers() > 0) {
      labelled_cloud_pub_.publish(toLabelledPointCloud2(cloud, result.labels, header, false));
    }
    superquadrics_pub_.publish(superquadricMarkers(result, header));
    labels_pub_.publish(noveltyLabelMarkers(array, result.up));
    if (node_params_.display_gaussians)
      gaussians_pub_.publish(
          gaussianMarkers(result, gaussiansHoldingNovelPoints(result, cloud), header));

    std::size_t novel_points = 0;
    for (int l : result.labels) novel_points += l > 0;
    std::ostringstream summary;
    summary << result.segments.size() << " novelties, " << novel_points << " novel points, "
            << result.superquadrics.size() << " superquadrics, "
            << result.disappeared_segments.size() << " disappearances, EMD " << result.emd_before
            << " -> " << result.emd_after;
    std::ostringstream alignment;
    alignment << result.alignment.status;
    if (result.alignment.attempted) {
      alignment << std::setprecision(3) << ", " << result.alignment.translation_m * 100.0 << " cm, "
                << result.alignment.rotation_deg << " deg, fitness "
                << result.alignment.fitness_m * 1000.0 << " mm, inliers "
                << result.alignment.inlier_fraction << ", cost -"
                << result.alignment.cost_reduction * 100.0 << " %, " << result.alignment.ms
                << " ms";
    }
    for (const std::string& w : result.warnings)
      NODELET_WARN_THROTTLE(kWarnPeriodS, "sweep at %.3f: %s", header.stamp.toSec(), w.c_str());
    NODELET_DEBUG("sweep at %.3f: %s in %.1f ms", header.stamp.toSec(), summary.str().c_str(), ms);
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++processed_;
    last_processing_ms_ = ms;
    max_processing_ms_ = std::max(max_processing_ms_, ms);
    last_result_ = summary.str();
    last_alignment_ = alignment.str();
    last_overlap_ = result.overlap;
    last_compared_ = true;
  } catch (const NoOverlapError& e) {
    // Not "no change": nothing is published for this sweep, and diagnostics turn ERROR.
    warnThrottled("overlap", std::string("sweep not compared: ") + e.what());
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++not_compared_;
    last_overlap_ = e.overlap();
    last_compared_ = false;
    last_error_ = e.what();
  } catch (const std::exception& e) {
    warnThrottled("failed", std::string("detection failed: ") + errorText(e));
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++failed_;
    last_error_ = errorText(e);
  }
}

}  // namespace novelty_detection

PLUGINLIB_EXPORT_CLASS(novelty_detection::NoveltyDetectorNodelet, nodelet::Nodelet)
