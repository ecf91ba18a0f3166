// Bridge between dynamic_reconfigure messages and the core Params: an entry named
// group_name (config/Detector.cfg) is the parameter group/name. Nothing else is listed, so
// adding a tunable to Detector.cfg needs no change here.
#pragma once

#include <dynamic_reconfigure/Config.h>

#include "novelty_detection/params.h"

namespace novelty_detection {

/// Sets every entry of `msg` that names a parameter to that parameter's value in `params`.
void paramsToConfigMsg(Params params, dynamic_reconfigure::Config& msg);

/// `params` with the values of `msg` applied and validated. Throws std::invalid_argument
/// for an entry that names no parameter or a value out of range (params unchanged).
Params applyConfigMsg(const dynamic_reconfigure::Config& msg, Params params);

}  // namespace novelty_detection
