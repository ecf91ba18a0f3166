// Reading and writing Params as YAML (the format of config/default.yaml). ROS-free.
#pragma once

#include <string>

#include "novelty_detection/params.h"

namespace novelty_detection {

/// Overrides `params` with the values in a YAML file laid out as config/default.yaml
/// (one section per group). Unknown groups or names and values of the wrong type throw
/// std::invalid_argument with a message naming the file and key; the result is validated.
void loadParamsYaml(const std::string& path, Params& params);

/// Same, from YAML text (used by tests and services).
void loadParamsYamlString(const std::string& yaml, Params& params);

/// The parameters as YAML with a comment per value, as config/default.yaml is written.
std::string paramsToYaml(Params params);

/// A Markdown table `| name | type | default | meaning |` of the given parameters.
std::string paramsToMarkdown(Params params);

}  // namespace novelty_detection
