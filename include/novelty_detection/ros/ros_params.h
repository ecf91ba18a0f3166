// Filling the core Params from ROS parameters with the same names (~group/name).
#pragma once

#include <ros/node_handle.h>

#include <string>
#include <vector>

#include "novelty_detection/params.h"

namespace novelty_detection {

/// Starts from the struct defaults (the one source of defaults), overrides every
/// `group/name` present under `nh`, and validates. Throws std::invalid_argument naming
/// the parameter when a value has the wrong type (e.g. a string for an int, a fractional
/// double for an int) or fails Params::validate().
Params loadRosParams(const ros::NodeHandle& nh);

/// The parameters under nh's namespace that the detector does not read, relative to it and
/// sorted (e.g. "gmm/max_component"): a misspelt name would otherwise be ignored in silence.
/// Known: every group/name of Params, every NodeParams name, "strict_parameters", and the
/// live-tuning server's own "tuning/..." entries.
std::vector<std::string> unknownDetectorParams(const ros::NodeHandle& nh);

}  // namespace novelty_detection
