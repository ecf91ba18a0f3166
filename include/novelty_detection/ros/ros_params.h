// Filling the core Params from ROS parameters with the same names (~group/name).
#pragma once

#include <ros/node_handle.h>

#include "novelty_detection/params.h"

namespace novelty_detection {

/// Starts from the struct defaults (the one source of defaults), overrides every
/// `group/name` present under `nh`, and validates. Throws std::invalid_argument naming
/// the parameter when a value has the wrong type (e.g. a string for an int, a fractional
/// double for an int) or fails Params::validate().
Params loadRosParams(const ros::NodeHandle& nh);

}  // namespace novelty_detection
