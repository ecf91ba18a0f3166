#include "shape_report.h"

#include <cmath>
#include <iomanip>
#include <sstream>

namespace novelty_detection {
namespace cli {

std::string shapeKindMarkdown(const std::vector<KindShapeError>& kinds) {
  std::ostringstream md;
  md << "\nSuperquadrics per object kind (found objects; the floor is the distance of the "
        "true points to the true shape, the sensor noise; semi-axis error over single-part "
        "objects fitted with one part, and over those of them seen with at least "
     << kWellSeenPoints << " points):\n\n"
     << "| kind | objects | surface error | floor | error / floor | semi-axis error | "
        "seen with >= "
     << kWellSeenPoints << " points |\n"
     << "|---|---:|---:|---:|---:|---:|---:|\n";
  md << std::fixed;
  for (const auto& k : kinds) {
    md << "| " << k.type << " | " << k.objects << " | " << std::setprecision(1) << 1000.0 * k.fit_m
       << " mm | " << 1000.0 * k.floor_m << " mm | " << std::setprecision(2) << k.ratio() << " | ";
    const auto axis = [&md](int objects, double error_m) {
      if (objects > 0)
        md << std::setprecision(1) << 1000.0 * error_m << " mm (" << objects << ")";
      else
        md << "-";
    };
    axis(k.axis_objects, k.semi_axis_error_m);
    md << " | ";
    axis(k.seen_axis_objects, k.seen_semi_axis_error_m);
    md << " |\n";
  }
  for (const auto& k : kinds) {
    if (k.type != "person") continue;
    md << "\nPeople: " << std::setprecision(1) << k.parts_mean << " parts per found person ("
       << k.parts_3_to_7 << " of " << k.objects << " with 3 to 7); the long axis of the part "
       << "fitted to the torso within 20 deg of up for " << k.main_part_within_20 << " of "
       << k.objects << "; of the " << k.seen_objects << " seen with at least " << kWellSeenPoints
       << " points, " << k.seen_parts_3_to_7 << " with 3 to 7 parts.\n";
  }
  return md.str();
}

nlohmann::json shapeKindJson(const std::vector<KindShapeError>& kinds) {
  nlohmann::json j = nlohmann::json::array();
  for (const auto& k : kinds)
    j.push_back(
        {{"type", k.type},
         {"objects", k.objects},
         {"surface_error_m", k.fit_m},
         {"floor_m", k.floor_m},
         {"error_over_floor", k.ratio()},
         {"semi_axis_objects", k.axis_objects},
         {"semi_axis_error_m", k.axis_objects > 0 ? k.semi_axis_error_m : 0.0},
         {"parts_mean", k.parts_mean},
         {"parts_3_to_7", k.parts_3_to_7},
         {"main_part_within_20deg", k.main_part_within_20},
         {"seen_objects", k.seen_objects},
         {"seen_parts_3_to_7", k.seen_parts_3_to_7},
         {"seen_semi_axis_objects", k.seen_axis_objects},
         {"seen_semi_axis_error_m", k.seen_axis_objects > 0 ? k.seen_semi_axis_error_m : 0.0}});
  return j;
}

nlohmann::json shapeObjectJson(const ObjectShapeError& e) {
  const auto number = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nullptr; };
  return {{"id", e.id},
          {"type", e.type},
          {"points", e.points},
          {"parts", e.parts},
          {"surface_error_m", e.fit_m},
          {"floor_m", e.floor_m},
          {"semi_axis_error_m", number(e.semi_axis_error_m)},
          {"main_part_tilt_deg", number(e.main_part_tilt_deg)}};
}

}  // namespace cli
}  // namespace novelty_detection
