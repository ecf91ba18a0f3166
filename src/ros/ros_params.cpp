#include "novelty_detection/ros/ros_params.h"

#include "novelty_detection/ros/node_params.h"

#include <ros/param.h>
#include <xmlrpcpp/XmlRpcValue.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace novelty_detection {
namespace {

std::string typeName(const XmlRpc::XmlRpcValue& v) {
  switch (v.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return "bool";
    case XmlRpc::XmlRpcValue::TypeInt:
      return "int";
    case XmlRpc::XmlRpcValue::TypeDouble:
      return "double";
    case XmlRpc::XmlRpcValue::TypeString:
      return "string";
    case XmlRpc::XmlRpcValue::TypeArray:
      return "list";
    case XmlRpc::XmlRpcValue::TypeStruct:
      return "dict";
    default:
      return "unsupported type";
  }
}

[[noreturn]] void wrongType(const std::string& key, const char* expected,
                            const XmlRpc::XmlRpcValue& v) {
  throw std::invalid_argument("parameter '" + key + "' must be " + expected + ", got a " +
                              typeName(v));
}

void assign(const std::string& key, XmlRpc::XmlRpcValue& v, bool& out) {
  if (v.getType() != XmlRpc::XmlRpcValue::TypeBoolean) wrongType(key, "a bool", v);
  out = static_cast<bool>(v);
}

void assign(const std::string& key, XmlRpc::XmlRpcValue& v, int& out) {
  if (v.getType() == XmlRpc::XmlRpcValue::TypeInt) {
    out = static_cast<int>(v);
    return;
  }
  if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble) {
    // YAML writes 1e6 as a double; accept whole numbers that fit in an int.
    const double d = static_cast<double>(v);
    if (std::isfinite(d) && d == std::floor(d) &&
        std::abs(d) <= static_cast<double>(std::numeric_limits<int>::max())) {
      out = static_cast<int>(d);
      return;
    }
  }
  wrongType(key, "an integer", v);
}

void assign(const std::string& key, XmlRpc::XmlRpcValue& v, double& out) {
  if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble) {
    out = static_cast<double>(v);
  } else if (v.getType() == XmlRpc::XmlRpcValue::TypeInt) {
    out = static_cast<int>(v);
  } else if (v.getType() == XmlRpc::XmlRpcValue::TypeString) {
    // rosparam reads YAML 1.1, where `1e-06` (no dot) is a string, while YAML 1.2 and
    // yaml-cpp read it as a number: accept a string that is entirely a finite number.
    const std::string text = static_cast<std::string>(v);
    std::size_t used = 0;
    double d = 0.0;
    try {
      d = std::stod(text, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != text.size() || !std::isfinite(d)) wrongType(key, "a number", v);
    out = d;
  } else {
    wrongType(key, "a number", v);
  }
}

void assign(const std::string& key, XmlRpc::XmlRpcValue& v, std::string& out) {
  if (v.getType() != XmlRpc::XmlRpcValue::TypeString) wrongType(key, "a string", v);
  out = static_cast<std::string>(v);
}

}  // namespace

Params loadRosParams(const ros::NodeHandle& nh) {
  Params params;
  params.visit([&nh](const char* group, const char* name, auto& value, const ParamInfo&) {
    const std::string key = std::string(group) + "/" + name;
    XmlRpc::XmlRpcValue v;
    if (!nh.getParam(key, v)) return;  // keep the struct default
    assign(nh.resolveName(key), v, value);
  });
  params.validate();
  return params;
}

std::vector<std::string> unknownDetectorParams(const ros::NodeHandle& nh) {
  std::set<std::string> known{"strict_parameters"};
  Params().visit([&known](const char* group, const char* name, auto&, const ParamInfo&) {
    known.insert(std::string(group) + "/" + name);
  });
  NodeParams().visit([&known](const char* name, auto&, const char*) { known.insert(name); });
  std::vector<std::string> names;
  if (!ros::param::getParamNames(names)) return {};
  const std::string prefix = nh.getNamespace() == "/" ? "/" : nh.getNamespace() + "/";
  std::vector<std::string> unknown;
  for (const std::string& full : names) {
    if (full.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string rel = full.substr(prefix.size());
    if (rel.rfind("tuning/", 0) == 0 || known.count(rel)) continue;
    unknown.push_back(rel);
  }
  std::sort(unknown.begin(), unknown.end());
  return unknown;
}

void NodeParams::validate() const {
  if (fixed_frame.empty()) throw std::invalid_argument("parameter 'fixed_frame' must not be empty");
  if (!std::isfinite(tile_size_m) || (tile_size_m > 0.0 && tile_size_m < 0.1))
    throw std::invalid_argument(
        "parameter 'tile_size_m' must be finite and 0 (no tiles) or at "
        "least 0.1");
  if (!(crop_margin_m >= 0.0) || !(crop_margin_m <= 1e4)) {
    throw std::invalid_argument("parameter 'crop_margin_m' must be in [0, 10000], got " +
                                std::to_string(crop_margin_m));
  }
  if (!(sensor_range_m > 0.0)) {
    throw std::invalid_argument("parameter 'sensor_range_m' must be > 0, got " +
                                std::to_string(sensor_range_m));
  }
  if (tile_cache_size < 1) {
    throw std::invalid_argument("parameter 'tile_cache_size' must be >= 1, got " +
                                std::to_string(tile_cache_size));
  }
  if (!(reference_display_voxel_m == 0.0 ||
        (reference_display_voxel_m >= 0.001 && reference_display_voxel_m <= 100.0))) {
    throw std::invalid_argument(
        "parameter 'reference_display_voxel_m' must be 0 (every point) or in [0.001, 100], "
        "got " +
        std::to_string(reference_display_voxel_m));
  }
  if (input_queue_size < 1) {
    throw std::invalid_argument("parameter 'input_queue_size' must be >= 1, got " +
                                std::to_string(input_queue_size));
  }
}

NodeParams loadNodeParams(const ros::NodeHandle& nh) {
  NodeParams params;
  params.visit([&nh](const char* name, auto& value, const char*) {
    XmlRpc::XmlRpcValue v;
    if (!nh.getParam(name, v)) return;
    assign(nh.resolveName(name), v, value);
  });
  params.validate();
  return params;
}

}  // namespace novelty_detection
