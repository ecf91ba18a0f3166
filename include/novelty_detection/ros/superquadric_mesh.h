// A closed triangle mesh of a superquadric surface, for display.
#pragma once

#include <Eigen/Core>

#include <vector>

#include "novelty_detection/types.h"

namespace novelty_detection {

/// Triangles (three vertices each, consecutive) of the superellipsoid surface of eq. 2
/// sampled on its parametric form
///   x = a1 C(eta,e1) C(w,e2), y = a2 C(eta,e1) S(w,e2), z = a3 S(eta,e1),
/// C(t,e) = sgn(cos t)|cos t|^e, S(t,e) = sgn(sin t)|sin t|^e, eta in [-pi/2, pi/2],
/// w in [-pi, pi), with `rings` steps in eta and `segments` steps in w, then moved to the
/// fixed frame (R * p + position). The mesh is closed and every triangle is wound
/// counter-clockwise seen from outside (rviz shades TRIANGLE_LIST by that winding).
std::vector<Eigen::Vector3d> superquadricTriangles(const Superquadric& sq, int rings = 16,
                                                   int segments = 24);

}  // namespace novelty_detection
