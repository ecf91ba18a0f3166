// Where each cloud's sensor was: stated, from the cloud's frame, or from its file. ROS-free.
//
// Visibility reasoning and disappearances need the sensor origin of a cloud. In order of
// precedence: an origin stated by the user (preprocess/reference_origin, current_origin;
// the CLI's --reference-origin / --current-origin); the cloud's own frame, when the cloud is
// in its sensor's frame (preprocess/sensor_frame, --sensor-frame, or an organised cloud
// without a VIEWPOINT); the file's VIEWPOINT; else unknown, and the stages that need it are
// off (the tools say so).
#pragma once

#include <Eigen/Core>

#include <optional>
#include <string>

#include "novelty_detection/types.h"

namespace novelty_detection {

/// "" (not stated) or three finite numbers "X Y Z"; throws std::invalid_argument naming
/// `param` otherwise.
std::optional<Eigen::Vector3f> parseOrigin(const std::string& param, const std::string& text);

/// Sets `cloud`'s sensor origin by the rule above and returns how it was found: "given",
/// "sensor frame", "sensor frame (organised cloud)", "viewpoint" or "unknown".
std::string resolveOrigin(Cloud& cloud, const std::optional<Eigen::Vector3f>& given,
                          bool sensor_frame);

}  // namespace novelty_detection
