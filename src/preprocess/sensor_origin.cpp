#include "novelty_detection/preprocess/sensor_origin.h"

#include <sstream>
#include <stdexcept>

namespace novelty_detection {

std::optional<Eigen::Vector3f> parseOrigin(const std::string& param, const std::string& text) {
  if (text.find_first_not_of(" \t") == std::string::npos) return std::nullopt;
  std::istringstream in(text);
  Eigen::Vector3d v;
  std::string rest;
  if (!(in >> v.x() >> v.y() >> v.z()) || (in >> rest) || !v.allFinite() ||
      v.cwiseAbs().maxCoeff() > 1e5) {
    throw std::invalid_argument("parameter " + param + " = '" + text +
                                "' must be empty or three numbers X Y Z [m] within 100 km");
  }
  return v.cast<float>();
}

std::string resolveOrigin(Cloud& cloud, const std::optional<Eigen::Vector3f>& given,
                          bool sensor_frame) {
  if (given) {
    setSensorOrigin(cloud, *given);
    return "given";
  }
  const bool viewpoint = sensorOriginKnown(cloud.sensor_origin_);
  if (sensor_frame || (cloud.height > 1 && !viewpoint)) {
    setSensorOrigin(cloud, Eigen::Vector3f::Zero());
    return sensor_frame ? "sensor frame" : "sensor frame (organised cloud)";
  }
  return viewpoint ? "viewpoint" : "unknown";
}

}  // namespace novelty_detection
