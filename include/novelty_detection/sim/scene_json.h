// JSON descriptions of simulated scenes (scene.json of simulate_scans). ROS-free.
#pragma once

#include <nlohmann/json.hpp>

#include "novelty_detection/sim/scene.h"

namespace novelty_detection {
namespace sim {

/// {"a": [a1,a2,a3], "epsilon": [e1,e2], "position": [x,y,z], "euler": [phi,theta,psi] (ZYZ,
/// rad), "orientation": [qx,qy,qz,qw]}: the fields of novelty_detect's superquadrics.json.
nlohmann::json superquadricToJson(const Superquadric& sq);

/// Pose as {"position": [x,y,z], "orientation": [qx,qy,qz,qw]}.
nlohmann::json poseToJson(const Eigen::Isometry3d& T);

/// The scene: config, sensor poses, point counts and the changed objects with their parts'
/// true superquadrics (docs/evaluation.md, "The simulator").
nlohmann::json sceneToJson(const ScenePair& scene);

}  // namespace sim
}  // namespace novelty_detection
