// Services and diagnostics of NoveltyDetectorNodelet (the sweep path is in
// novelty_detector_nodelet.cpp).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <stdexcept>
#include <string>

#include "novelty_detection/error_text.h"
#include "novelty_detection/io/cloud_io.h"
#include "novelty_detection/io/reference_sweeps.h"
#include "novelty_detection/preprocess/ignore_regions.h"
#include "novelty_detection/preprocess/input_check.h"
#include "novelty_detection/ros/conversions.h"
#include "novelty_detection/ros/novelty_detector_nodelet.h"
#include "novelty_detection/ros/reconfigure.h"
#include "novelty_detection/ros/result_messages.h"

namespace novelty_detection {
namespace {

/// Where ~save_reference may write `request`: inside `directory` (empty: $ROS_HOME, else
/// ~/.ros, then novelty_detection; created when missing), after resolving '..' and the
/// symlinks of the part that exists. Throws std::runtime_error naming both otherwise.
std::string confinedSavePath(const std::string& directory, const std::string& request) {
  namespace fs = std::filesystem;
  fs::path dir(directory);
  if (dir.empty()) {
    const char* ros_home = std::getenv("ROS_HOME");
    const char* home = std::getenv("HOME");
    dir =
        ros_home && *ros_home ? fs::path(ros_home) : fs::path(home && *home ? home : ".") / ".ros";
    dir /= "novelty_detection";
  }
  if (request.empty()) throw std::runtime_error("no path given");
  std::error_code ec;
  fs::create_directories(dir, ec);
  const fs::path root = fs::canonical(dir, ec);
  if (ec)
    throw std::runtime_error("~save_directory '" + dir.string() + "' is unusable: " + ec.message());
  const fs::path asked(request);
  const fs::path target = fs::weakly_canonical(asked.is_absolute() ? asked : root / asked, ec);
  if (ec) throw std::runtime_error("cannot resolve '" + request + "': " + ec.message());
  const fs::path rel = target.lexically_relative(root);
  if (rel.empty() || rel == "." || *rel.begin() == "..")
    throw std::runtime_error("'" + request + "' is outside ~save_directory '" + root.string() +
                             "'");
  return target.string();
}

}  // namespace

bool NoveltyDetectorNodelet::onCaptureReference(std_srvs::Trigger::Request&,
                                                std_srvs::Trigger::Response& res) {
  if (!params_error_.empty()) {
    res.success = false;
    res.message = "not running: " + params_error_;
    return true;
  }
  capture_next_ = true;
  res.success = true;
  res.message = "the next sweep becomes the reference";
  NODELET_INFO("%s", res.message.c_str());
  return true;
}

bool NoveltyDetectorNodelet::onSetReference(SetReference::Request& req,
                                            SetReference::Response& res) {
  try {
    if (!params_error_.empty()) throw std::runtime_error("not running: " + params_error_);
    const std::string what = setReferenceFrom(req.path);
    res.success = true;
    res.message = "reference set from " + req.path + " (" + what + ")";
    NODELET_INFO("%s", res.message.c_str());
  } catch (const std::exception& e) {
    res.success = false;
    res.message = errorText(e);
    NODELET_WARN("set_reference failed: %s", errorText(e).c_str());
  }
  return true;
}

bool NoveltyDetectorNodelet::onSaveReference(SaveReference::Request& req,
                                             SaveReference::Response& res) {
  try {
    if (!params_error_.empty()) throw std::runtime_error("not running: " + params_error_);
    if (!reference_->hasMap()) throw std::runtime_error("there is no reference to save");
    const std::string path = confinedSavePath(node_params_.save_directory, req.path);
    const Cloud map = reference_->map();
    const ReferenceViews views = reference_->views();
    if (!views.empty() && !hasPcdExtension(path)) {
      // A map of several sweeps: a reference directory keeps each sweep's viewpoint.
      std::vector<CloudFile> sweeps(views.origins.size());
      for (std::size_t k = 0; k < sweeps.size(); ++k)
        sweeps[k].T_frame_sensor.translation() = views.origins[k].cast<double>();
      for (std::size_t i = 0; i < map.size(); ++i) sweeps[views.sweep[i]].cloud.push_back(map[i]);
      saveReferenceSweeps(path, sweeps);
      res.message = "saved " + std::to_string(map.size()) + " points in " +
                    std::to_string(sweeps.size()) + " sweeps to " + path + "/";
    } else {
      if (!views.empty())
        NODELET_WARN(
            "saving a map of %zu sweeps as one file keeps no viewpoint; give a "
            "directory name (no .pcd) to keep them",
            views.origins.size());
      saveCloudAtomic(path, map, viewpointOf(map));
      res.message = "saved " + std::to_string(map.size()) + " points to " + path;
    }
    res.success = true;
    NODELET_INFO("%s", res.message.c_str());
  } catch (const std::exception& e) {
    res.success = false;
    res.message = errorText(e);
    NODELET_WARN("save_reference failed: %s", errorText(e).c_str());
  }
  return true;
}

bool NoveltyDetectorNodelet::onDetect(Detect::Request& req, Detect::Response& res) {
  const auto t0 = std::chrono::steady_clock::now();
  try {
    if (!params_error_.empty()) throw std::runtime_error("not running: " + params_error_);
    if (!reference_->hasMap()) throw std::runtime_error("no reference map set");
    Cloud cloud = toFixedFrame(req.cloud, true);
    setSensorPose(cloud, req.cloud.header.frame_id, req.cloud.header.stamp);
    const Result result = detect(cloud, req.cloud.header.frame_id, req.cloud.header.stamp);
    std_msgs::Header header = req.cloud.header;
    header.frame_id = node_params_.fixed_frame;
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    res.novelties = toNoveltyArray(result, header, s);
    res.labelled_cloud = toLabelledPointCloud2(cloud, result.labels, header, false);
    res.success = true;
    res.message = std::to_string(result.segments.size()) + " novelties";
  } catch (const std::exception& e) {
    res.success = false;
    res.message = errorText(e);
    NODELET_WARN("detect failed: %s", errorText(e).c_str());
  }
  return true;
}

bool NoveltyDetectorNodelet::onSetIgnoreRegions(SetIgnoreRegions::Request& req,
                                                SetIgnoreRegions::Response& res) {
  std::lock_guard<std::mutex> lock(params_mutex_);
  try {
    if (!params_error_.empty()) throw std::runtime_error("not running: " + params_error_);
    Params updated = params_;
    updated.preprocess.ignore_regions = req.regions;
    const std::vector<IgnoreRegion> regions = parseIgnoreRegions(req.regions);
    reference_->setParams(updated);
    params_ = updated;
    res.success = true;
    res.message = regions.empty() ? std::string("no ignore region")
                                  : std::to_string(regions.size()) +
                                        " ignore region(s): " + formatIgnoreRegions(regions);
    NODELET_INFO("%s", res.message.c_str());
  } catch (const std::exception& e) {
    res.success = false;
    res.message = errorText(e);
    NODELET_WARN("set_ignore_regions refused: %s", errorText(e).c_str());
  }
  return true;
}

void NoveltyDetectorNodelet::resetTracks() {
  std::lock_guard<std::mutex> lock(tracks_mutex_);
  if (novelty_tracks_) novelty_tracks_->reset();
  if (disappearance_tracks_) disappearance_tracks_->reset();
}

void NoveltyDetectorNodelet::trackChanges(const Result& result, const Cloud& cloud, double stamp,
                                          NoveltyArray& array) {
  const TrackingParams params = currentParams().tracking;
  const Eigen::AlignedBox3d extent = usableExtent(cloud);
  std::lock_guard<std::mutex> lock(tracks_mutex_);
  auto track = [&](ChangeTracker& tracker, const std::vector<Segment>& segments) {
    tracker.setParams(params);
    const std::vector<std::uint32_t> ids = tracker.update(segments, stamp, extent);
    std::vector<const ChangeTrack*> tracks;
    for (std::uint32_t id : ids) tracks.push_back(tracker.track(id));
    return tracks;
  };
  // Pointers stay valid until the next update of the same tracker.
  const auto novel = track(*novelty_tracks_, result.segments);
  const auto gone = result.disappearances_checked
                        ? track(*disappearance_tracks_, result.disappeared_segments)
                        : std::vector<const ChangeTrack*>{};
  setTracks(array, novel, gone);
}

void NoveltyDetectorNodelet::onReconfigure(DetectorConfig& config, uint32_t /*level*/) {
  dynamic_reconfigure::Config msg;
  config.__toMessage__(msg);
  std::lock_guard<std::mutex> lock(params_mutex_);
  try {
    const Params updated = applyConfigMsg(msg, params_);
    reference_->setParams(updated);
    params_ = updated;
    NODELET_INFO("parameters updated; reference models are rebuilt on the next sweep");
  } catch (const std::exception& e) {
    NODELET_WARN("reconfigure refused: %s", errorText(e).c_str());
    paramsToConfigMsg(params_, msg);
    config.__fromMessage__(msg);
  }
}

void NoveltyDetectorNodelet::warnThrottled(const std::string& category, const std::string& text) {
  const ros::WallTime now = ros::WallTime::now();
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    auto& last = last_warning_[category];
    if (last.first == text && (now - last.second).toSec() < kWarnPeriodS) return;
    last = {text, now};
  }
  NODELET_WARN("%s", text.c_str());
}

void NoveltyDetectorNodelet::diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  if (!params_error_.empty()) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::ERROR, "invalid parameters");
  } else if (!reference_->hasMap()) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, "no reference map");
  } else if (!last_compared_) {
    char text[96];
    std::snprintf(text, sizeof text, "last sweep not compared: overlap %.3f with the map",
                  last_overlap_);
    stat.summary(diagnostic_msgs::DiagnosticStatus::ERROR, text);
  } else if (!last_error_.empty() && processed_ == 0) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, last_error_);
  } else {
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "running");
  }
  stat.add("sweeps received", received_);
  stat.add("sweeps processed", processed_);
  stat.add("sweeps dropped (stale)", dropped_);
  stat.add("sweeps lost upstream", lost_upstream_);
  stat.add("sweeps rejected", rejected_);
  stat.add("detections failed", failed_);
  stat.add("sweeps not compared (no overlap)", not_compared_);
  stat.add("last overlap", last_overlap_);
  stat.add("transform failures", tf_failures_);
  stat.add("last processing time [ms]", last_processing_ms_);
  stat.add("max processing time [ms]", max_processing_ms_);
  stat.add("last result", last_result_);
  stat.add("last error", last_error_);
  stat.add("last alignment", last_alignment_);
  stat.add("reference points", reference_->mapSize());
  stat.add("reference models cached", reference_->cachedModels());
  stat.add("reference models built", reference_->modelsBuilt());
}

}  // namespace novelty_detection
