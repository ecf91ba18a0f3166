#include "novelty_detection/ros/superquadric_mesh.h"

#include "novelty_detection/shape/superquadric.h"

namespace novelty_detection {

std::vector<Eigen::Vector3d> superquadricTriangles(const Superquadric& sq, int resolution) {
  const TriangleMesh mesh = triangleMesh(sq, resolution);
  std::vector<Eigen::Vector3d> tris;
  tris.reserve(mesh.triangles.size() * 3);
  for (const auto& t : mesh.triangles) {
    const auto& a = mesh.vertices[t[0]];
    const auto& b = mesh.vertices[t[1]];
    const auto& c = mesh.vertices[t[2]];
    if (!a.allFinite() || !b.allFinite() || !c.allFinite()) continue;
    tris.insert(tris.end(), {a, b, c});
  }
  return tris;
}

}  // namespace novelty_detection
