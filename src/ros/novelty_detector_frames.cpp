// Frames, sensor pose and reference of NoveltyDetectorNodelet: sweeps into ~fixed_frame, the
// sensor pose from tf, the reference file, and the part of the map a sweep is compared with
// (the sweep path is in novelty_detector_nodelet.cpp, services in novelty_detector_services.cpp).
#include <tf2_eigen/tf2_eigen.h>

#include <cmath>
#include <exception>
#include <stdexcept>
#include <string>

#include "novelty_detection/error_text.h"
#include "novelty_detection/io/cloud_io.h"
#include "novelty_detection/io/reference_sweeps.h"
#include "novelty_detection/preprocess/input_check.h"
#include "novelty_detection/preprocess/sensor_origin.h"
#include "novelty_detection/preprocess/voxel_filter.h"
#include "novelty_detection/ros/conversions.h"
#include "novelty_detection/ros/novelty_detector_nodelet.h"
#include "novelty_detection/ros/ros_params.h"
#include "novelty_detection/ros/sensor_pose.h"

namespace novelty_detection {

Params NoveltyDetectorNodelet::currentParams() const {
  std::lock_guard<std::mutex> lock(params_mutex_);
  return params_;
}

std::string NoveltyDetectorNodelet::setReferenceFrom(const std::string& path) {
  ReferenceMap map = loadReference(path, referenceLimits());
  const PreprocessParams given = currentParams().preprocess;
  std::string how = "sweep viewpoints";
  if (map.views.empty()) {
    how =
        resolveOrigin(map.cloud, parseOrigin("preprocess/reference_origin", given.reference_origin),
                      given.sensor_frame);
    if (how == "unknown")
      NODELET_WARN(
          "the reference file has no viewpoint: visibility and disappearances are off; set "
          "~preprocess/reference_origin or ~preprocess/sensor_frame");
  }
  reference_->setMap(map.cloud, map.views);
  resetTracks();
  publishReferenceDisplay(map.cloud);
  const std::size_t sweeps = map.views.empty() ? 1 : map.views.origins.size();
  return std::to_string(map.cloud.size()) + " points, " + std::to_string(sweeps) +
         (sweeps == 1 ? " sweep" : " sweeps") + ", viewpoint: " + how;
}

void NoveltyDetectorNodelet::publishReferenceDisplay(const Cloud& map) {
  if (!node_params_.publish_reference) return;
  std_msgs::Header header;
  header.frame_id = node_params_.fixed_frame;
  header.stamp = ros::Time::now();
  try {
    const double leaf = node_params_.reference_display_voxel_m;
    reference_pub_.publish(toPointCloud2(leaf > 0.0 ? voxelDownsample(map, leaf) : map, header));
  } catch (const std::exception& e) {
    // Display only: the detection goes on with the map.
    NODELET_WARN("cannot publish the reference for display: %s", errorText(e).c_str());
  }
}

LoadLimits NoveltyDetectorNodelet::referenceLimits() const {
  LoadLimits limits;
  limits.max_points = static_cast<std::uint64_t>(currentParams().preprocess.max_points);
  return limits;
}

void NoveltyDetectorNodelet::loadReferenceFile(const std::string& path) {
  try {
    const std::string what = setReferenceFrom(path);
    NODELET_INFO("reference map loaded from %s: %s", path.c_str(), what.c_str());
  } catch (const std::exception& e) {
    NODELET_ERROR("cannot use reference file: %s", errorText(e).c_str());
    {
      std::lock_guard<std::mutex> lock(status_mutex_);
      reference_error_ = "error: cannot use ~reference_file '" + path + "': " + errorText(e);
      if (init_done_) publishStatus(reference_error_);  // else onInit publishes it after "ready"
    }
    std::lock_guard<std::mutex> lock(stats_mutex_);
    last_error_ = errorText(e);
  }
}

Cloud NoveltyDetectorNodelet::toFixedFrame(const sensor_msgs::PointCloud2& msg,
                                           bool wait_for_transform) const {
  Cloud cloud = fromPointCloud2(msg);
  const std::string frame =
      msg.header.frame_id.empty() ? node_params_.fixed_frame : msg.header.frame_id;
  if (frame == node_params_.fixed_frame) return cloud;
  std::string why;
  if (wait_for_transform &&
      !tf_buffer_->canTransform(node_params_.fixed_frame, frame, msg.header.stamp, &why)) {
    throw std::runtime_error("no transform from '" + frame + "' to '" + node_params_.fixed_frame +
                             "': " + why);
  }
  const Eigen::Isometry3d T_fixed_sensor = tf2::transformToEigen(
      tf_buffer_->lookupTransform(node_params_.fixed_frame, frame, msg.header.stamp));
  const Eigen::Isometry3f T = T_fixed_sensor.cast<float>();
  for (auto& p : cloud) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
    p.getVector3fMap() = T * p.getVector3fMap();
  }
  return cloud;
}

void NoveltyDetectorNodelet::setSensorPose(Cloud& cloud, const std::string& cloud_frame,
                                           const ros::Time& stamp) const {
  const std::string sensor_frame =
      node_params_.sensor_frame.empty() ? cloud_frame : node_params_.sensor_frame;
  if (sensor_frame.empty() || sensor_frame == node_params_.fixed_frame) return;
  // The sweep's own frame was waited for by the tf filter; a separate ~sensor_frame may lag
  // behind it by a few tf messages, or end before the sweep's stamp (a tilting laser's last
  // line, the end of a bag): sensor_pose.h.
  try {
    const SensorPose pose = lookupSensorPose(*tf_buffer_, node_params_.fixed_frame, sensor_frame,
                                             stamp, 0.3, kSensorPoseToleranceS);
    setSensorOrigin(cloud, pose.T_fixed_sensor.translation().cast<float>());
    cloud.sensor_orientation_ = Eigen::Quaternionf(pose.T_fixed_sensor.linear().cast<float>());
  } catch (const tf2::TransformException& e) {
    NODELET_WARN_THROTTLE(kWarnPeriodS, "no sensor pose for the sweep: %s", errorText(e).c_str());
  }
}

Result NoveltyDetectorNodelet::detect(const Cloud& cloud, const std::string& cloud_frame,
                                      const ros::Time& stamp, Cloud* reference) const {
  Eigen::Vector3d lo, hi;
  if (!usableBounds(cloud, lo, hi)) {
    throw std::invalid_argument("the sweep has no finite point (" + std::to_string(cloud.size()) +
                                " points)");
  }
  // Compare only the part of the map this sweep can see: its extent plus a margin, and
  // within the sensor's range of its origin when the sensor frame is known.
  lo.array() -= node_params_.crop_margin_m;
  hi.array() += node_params_.crop_margin_m;
  // The sensor sits at ~sensor_frame, or else at the origin of the cloud's own frame when
  // that is not the fixed frame (a sweep in the laser frame).
  const std::string sensor_frame =
      node_params_.sensor_frame.empty() ? cloud_frame : node_params_.sensor_frame;
  if (!sensor_frame.empty() && sensor_frame != node_params_.fixed_frame) {
    try {
      const Eigen::Vector3d origin =
          lookupSensorPose(*tf_buffer_, node_params_.fixed_frame, sensor_frame, stamp, 0.0,
                           kSensorPoseToleranceS)
              .T_fixed_sensor.translation();
      const Eigen::Vector3d range = Eigen::Vector3d::Constant(node_params_.sensor_range_m);
      lo = lo.cwiseMax(origin - range);
      hi = hi.cwiseMin(origin + range);
    } catch (const tf2::TransformException& e) {
      NODELET_WARN_THROTTLE(kWarnPeriodS, "no sensor origin, cropping by extent only: %s",
                            errorText(e).c_str());
    }
  }
  const auto pipeline = reference_->pipelineFor(lo, hi);
  Result result = pipeline->detect(cloud);
  if (reference) *reference = pipeline->referenceCloud();
  return result;
}

}  // namespace novelty_detection
