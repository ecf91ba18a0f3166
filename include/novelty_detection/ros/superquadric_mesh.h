// Triangle soup of a superquadric surface, as rviz's TRIANGLE_LIST wants it.
#pragma once

#include <Eigen/Core>

#include <vector>

#include "novelty_detection/types.h"

namespace novelty_detection {

/// Triangles (three consecutive vertices each, fixed frame) of the core's closed mesh
/// (novelty_detection::triangleMesh, counter-clockwise seen from outside: rviz shades
/// TRIANGLE_LIST by that winding). Triangles with a non-finite vertex are left out.
std::vector<Eigen::Vector3d> superquadricTriangles(const Superquadric& sq, int resolution = 8);

}  // namespace novelty_detection
