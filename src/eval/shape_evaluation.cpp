#include "novelty_detection/eval/shape_evaluation.h"

#include <nlohmann/json.hpp>

#include <algorithm>
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

/// The sizes, exponents, position and ZYZ angles (`euler`) of a superquadric entry; throws
/// `invalid` when its sizes or position are not usable.
Superquadric superquadricFromJson(const nlohmann::json& e, const nlohmann::json& euler,
                                  const std::string& invalid) {
  Superquadric sq;
  sq.a = vec3(e.at("a"));
  sq.e1 = e.at("epsilon").at(0).get<double>();
  sq.e2 = e.at("epsilon").at(1).get<double>();
  sq.position = vec3(e.at("position"));
  sq.euler = vec3(euler);
  if (!sq.a.allFinite() || (sq.a.array() <= 0.0).any() || !sq.position.allFinite())
    throw std::runtime_error(invalid);
  return sq;
}

/// Mean over the points of `id` in `truth` of the distance to the nearest of `parts`.
double meanDistance(const Cloud& cloud, const std::vector<int>& truth, int id,
                    const std::vector<const Superquadric*>& parts) {
  double total = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (truth[i] != id) continue;
    const Eigen::Vector3d p = cloud[i].getVector3fMap().cast<double>();
    if (!p.allFinite()) continue;
    double best = std::numeric_limits<double>::infinity();
    for (const Superquadric* sq : parts) best = std::min(best, surfaceDistance(*sq, p));
    if (std::isfinite(best)) {
      total += best;
      ++n;
    }
  }
  return n > 0 ? total / static_cast<double>(n) : std::numeric_limits<double>::quiet_NaN();
}

/// Index of the nearest of `parts` to p (surface distance); -1 when none is finite.
int nearestPart(const std::vector<const Superquadric*>& parts, const Eigen::Vector3d& p) {
  int best = -1;
  double best_d = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < parts.size(); ++k) {
    const double d = surfaceDistance(*parts[k], p);
    if (d < best_d) {
      best_d = d;
      best = static_cast<int>(k);
    }
  }
  return best;
}

/// The superquadrics by the segment they were fitted to; throws std::invalid_argument naming
/// `who` when `truth` does not label `cloud`.
std::map<int, std::vector<const Superquadric*>> bySegment(
    const Cloud& cloud, const std::vector<int>& truth,
    const std::vector<Superquadric>& superquadrics, const char* who) {
  if (truth.size() != cloud.size()) {
    throw std::invalid_argument(std::string(who) + ": " + std::to_string(truth.size()) +
                                " labels for a cloud of " + std::to_string(cloud.size()));
  }
  std::map<int, std::vector<const Superquadric*>> by_segment;
  for (const auto& sq : superquadrics) by_segment[sq.segment].push_back(&sq);
  return by_segment;
}

}  // namespace

std::vector<TrueShape> readTrueShapes(const std::string& scene_json) {
  std::ifstream in(scene_json);
  if (!in) throw std::runtime_error("cannot read '" + scene_json + "'");
  std::vector<TrueShape> out;
  try {
    const nlohmann::json doc = nlohmann::json::parse(in);
    for (const auto& o : doc.at("objects")) {
      TrueShape t;
      t.id = o.at("id").get<int>();
      t.type = o.at("type").get<std::string>();
      for (const auto& part : o.at("parts")) {
        Superquadric sq = superquadricFromJson(
            part, part.at("euler"), "object " + std::to_string(t.id) + " has an invalid part");
        sq.segment = t.id;
        t.parts.push_back(sq);
      }
      out.push_back(std::move(t));
    }
  } catch (const std::runtime_error& e) {
    throw std::runtime_error("'" + scene_json + "': " + e.what());
  } catch (const std::exception& e) {
    throw std::runtime_error("'" + scene_json + "' has no valid objects: " + e.what());
  }
  return out;
}

const Superquadric* mainFittedPart(const Points3d& points,
                                   const std::vector<const Superquadric*>& true_parts,
                                   const std::vector<const Superquadric*>& fitted) {
  if (fitted.empty()) return nullptr;
  std::size_t body = 0;
  for (std::size_t k = 1; k < true_parts.size(); ++k)
    if (volume(*true_parts[k]) > volume(*true_parts[body])) body = k;
  std::vector<int> votes(fitted.size(), 0);
  for (const auto& p : points) {
    if (!p.allFinite() || nearestPart(true_parts, p) != static_cast<int>(body)) continue;
    const int k = nearestPart(fitted, p);
    if (k >= 0) ++votes[static_cast<std::size_t>(k)];
  }
  const auto most = std::max_element(votes.begin(), votes.end());
  if (*most > 0) return fitted[static_cast<std::size_t>(most - votes.begin())];
  const Superquadric* main = fitted.front();
  for (const Superquadric* sq : fitted)
    if (volume(*sq) > volume(*main)) main = sq;
  return main;
}

std::vector<ObjectShapeError> scoreShapesByObject(const Cloud& cloud, const std::vector<int>& truth,
                                                  const SceneScore& score,
                                                  const std::vector<Superquadric>& superquadrics,
                                                  const std::vector<TrueShape>& shapes) {
  const auto by_segment = bySegment(cloud, truth, superquadrics, "scoreShapesByObject");
  std::vector<ObjectShapeError> out;
  for (const ObjectScore& obj : score.objects) {
    if (!obj.found) continue;
    const auto fitted = by_segment.find(obj.best_segment);
    const auto shape = std::find_if(shapes.begin(), shapes.end(),
                                    [&](const TrueShape& t) { return t.id == obj.id; });
    if (fitted == by_segment.end() || shape == shapes.end() || shape->parts.empty()) continue;
    std::vector<const Superquadric*> true_parts;
    for (const auto& sq : shape->parts) true_parts.push_back(&sq);
    ObjectShapeError e;
    e.id = obj.id;
    e.type = shape->type;
    e.points = obj.points;
    e.fit_m = meanDistance(cloud, truth, obj.id, fitted->second);
    e.floor_m = meanDistance(cloud, truth, obj.id, true_parts);
    if (!std::isfinite(e.fit_m) || !std::isfinite(e.floor_m)) continue;
    e.parts = static_cast<int>(fitted->second.size());
    Points3d object_points;
    for (std::size_t i = 0; i < cloud.size(); ++i)
      if (truth[i] == obj.id) object_points.push_back(cloud[i].getVector3fMap().cast<double>());
    const Superquadric* main = mainFittedPart(object_points, true_parts, fitted->second);
    int long_axis = 0;
    main->a.maxCoeff(&long_axis);
    const double up_cos = std::abs(main->rotation().col(long_axis).z());
    e.main_part_tilt_deg = std::acos(std::min(1.0, up_cos)) * 180.0 / M_PI;
    if (shape->parts.size() == 1 && fitted->second.size() == 1) {
      Eigen::Vector3d a = fitted->second.front()->a, b = shape->parts.front().a;
      std::sort(a.data(), a.data() + 3);
      std::sort(b.data(), b.data() + 3);
      e.semi_axis_error_m = (a - b).cwiseAbs().mean();
    }
    out.push_back(e);
  }
  return out;
}

std::vector<KindShapeError> summarizeShapesByKind(const std::vector<ObjectShapeError>& objects) {
  std::map<std::string, KindShapeError> kinds;
  for (const auto& o : objects) {
    KindShapeError& k = kinds[o.type];
    k.type = o.type;
    ++k.objects;
    k.fit_m += o.fit_m;
    k.floor_m += o.floor_m;
    k.parts_mean += o.parts;
    if (o.parts >= 3 && o.parts <= 7) ++k.parts_3_to_7;
    if (o.main_part_tilt_deg <= 20.0) ++k.main_part_within_20;
    if (std::isfinite(o.semi_axis_error_m)) {
      ++k.axis_objects;
      k.semi_axis_error_m += o.semi_axis_error_m;
    }
    if (o.points < kWellSeenPoints) continue;
    ++k.seen_objects;
    if (o.parts >= 3 && o.parts <= 7) ++k.seen_parts_3_to_7;
    if (std::isfinite(o.semi_axis_error_m)) {
      ++k.seen_axis_objects;
      k.seen_semi_axis_error_m += o.semi_axis_error_m;
    }
  }
  std::vector<KindShapeError> out;
  for (auto& [type, k] : kinds) {
    k.fit_m /= k.objects;
    k.floor_m /= k.objects;
    k.parts_mean /= k.objects;
    if (k.axis_objects > 0) k.semi_axis_error_m /= k.axis_objects;
    if (k.seen_axis_objects > 0) k.seen_semi_axis_error_m /= k.seen_axis_objects;
    out.push_back(k);
  }
  return out;
}

std::vector<Superquadric> readSuperquadricsJson(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read '" + path + "'");
  std::vector<Superquadric> out;
  try {
    const nlohmann::json doc = nlohmann::json::parse(in);
    if (!doc.is_array()) throw std::runtime_error("top level is not a list");
    for (const auto& e : doc) {
      Superquadric sq = superquadricFromJson(e, e.at("orientation").at("euler"),
                                             "superquadric with invalid sizes or position");
      sq.segment = e.at("segment").get<int>();
      sq.points = e.value("points", 0);
      sq.residual = e.value("residual", 0.0);
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
  const auto by_segment = bySegment(cloud, truth, superquadrics, "scoreShapes");

  ShapeScore out;
  double sum = 0.0;
  for (const ObjectScore& obj : score.objects) {
    if (!obj.found) continue;
    const auto parts = by_segment.find(obj.best_segment);
    if (parts == by_segment.end()) continue;
    const double mean = meanDistance(cloud, truth, obj.id, parts->second);
    if (!std::isfinite(mean)) continue;
    out.per_object.emplace_back(obj.id, mean);
    sum += mean;
    ++out.objects;
  }
  if (out.objects > 0) out.mean_surface_distance_m = sum / out.objects;
  return out;
}

}  // namespace novelty_detection
