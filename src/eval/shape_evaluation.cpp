#include "novelty_detection/eval/shape_evaluation.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <stdexcept>

#include "novelty_detection/shape/superquadric.h"

namespace novelty_detection {
namespace {

Eigen::Vector3d vec3(const nlohmann::json& j) {
  if (!j.is_array() || j.size() != 3) throw std::runtime_error("expected a 3-vector");
  return Eigen::Vector3d(j[0].get<double>(), j[1].get<double>(), j[2].get<double>());
}

}  // namespace

std::vector<Superquadric> readSuperquadricsJson(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read '" + path + "'");
  std::vector<Superquadric> out;
  try {
    const nlohmann::json doc = nlohmann::json::parse(in);
    if (!doc.is_array()) throw std::runtime_error("top level is not a list");
    for (const auto& e : doc) {
      Superquadric sq;
      sq.segment = e.at("segment").get<int>();
      sq.a = vec3(e.at("a"));
      sq.e1 = e.at("epsilon").at(0).get<double>();
      sq.e2 = e.at("epsilon").at(1).get<double>();
      sq.position = vec3(e.at("position"));
      sq.euler = vec3(e.at("orientation").at("euler"));
      sq.points = e.value("points", 0);
      sq.residual = e.value("residual", 0.0);
      if (!sq.a.allFinite() || (sq.a.array() <= 0.0).any() || !sq.position.allFinite()) {
        throw std::runtime_error("superquadric with invalid sizes or position");
      }
      out.push_back(sq);
    }
  } catch (const std::runtime_error& e) {
    throw std::runtime_error("'" + path + "': " + e.what());
  } catch (const std::exception& e) {
    throw std::runtime_error("'" + path + "' is not a valid superquadrics file: " + e.what());
  }
  return out;
}

ShapeScore scoreShapes(const Cloud& cloud, const std::vector<int>& truth, const SceneScore& score,
                       const std::vector<Superquadric>& superquadrics) {
  if (truth.size() != cloud.size()) {
    throw std::invalid_argument("scoreShapes: " + std::to_string(truth.size()) +
                                " labels for a cloud of " + std::to_string(cloud.size()));
  }
  std::map<int, std::vector<const Superquadric*>> by_segment;
  for (const auto& sq : superquadrics) by_segment[sq.segment].push_back(&sq);

  ShapeScore out;
  double sum = 0.0;
  for (const ObjectScore& obj : score.objects) {
    if (!obj.found) continue;
    const auto parts = by_segment.find(obj.best_segment);
    if (parts == by_segment.end()) continue;
    double total = 0.0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      if (truth[i] != obj.id) continue;
      const Eigen::Vector3d p = cloud[i].getVector3fMap().cast<double>();
      if (!p.allFinite()) continue;
      double best = std::numeric_limits<double>::infinity();
      for (const Superquadric* sq : parts->second) best = std::min(best, surfaceDistance(*sq, p));
      if (std::isfinite(best)) {
        total += best;
        ++n;
      }
    }
    if (n == 0) continue;
    out.per_object.emplace_back(obj.id, total / static_cast<double>(n));
    sum += total / static_cast<double>(n);
    ++out.objects;
  }
  if (out.objects > 0) out.mean_surface_distance_m = sum / out.objects;
  return out;
}

}  // namespace novelty_detection
