#include "detect_report.h"

#include <cmath>

#include "novelty_detection/preprocess/sensor_origin.h"

namespace novelty_detection {
namespace cli {
namespace {

namespace nd = novelty_detection;
using nlohmann::json;

json vec(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

json originJson(const nd::Cloud& cloud, const std::string& how) {
  if (!nd::sensorOriginKnown(cloud.sensor_origin_)) return {{"position", nullptr}, {"from", how}};
  return {{"position", vec(cloud.sensor_origin_.head<3>().cast<double>())}, {"from", how}};
}

json cacheJson(const nd::ReferenceCacheUse& use) {
  json j = {{"state", use.state}};
  if (use.state != "off") j["key"] = use.key;
  if (!use.message.empty()) j["message"] = use.message;
  return j;
}

}  // namespace

// A distinct, deterministic colour per segment id (golden-ratio hue walk); grey = not novel.
void colour(int id, std::uint8_t& r, std::uint8_t& g, std::uint8_t& b) {
  if (id <= 0) {
    r = g = b = 150;
    return;
  }
  const double h = std::fmod(id * 0.618033988749895, 1.0) * 6.0;
  const double x = 1.0 - std::abs(std::fmod(h, 2.0) - 1.0);
  double rf = 0, gf = 0, bf = 0;
  switch (static_cast<int>(h)) {
    case 0:
      rf = 1, gf = x;
      break;
    case 1:
      rf = x, gf = 1;
      break;
    case 2:
      gf = 1, bf = x;
      break;
    case 3:
      gf = x, bf = 1;
      break;
    case 4:
      rf = x, bf = 1;
      break;
    default:
      rf = 1, bf = x;
      break;
  }
  r = static_cast<std::uint8_t>(55 + 200 * rf);
  g = static_cast<std::uint8_t>(55 + 200 * gf);
  b = static_cast<std::uint8_t>(55 + 200 * bf);
}

json superquadricsJson(const std::vector<nd::Superquadric>& superquadrics) {
  json list = json::array();
  for (const auto& sq : superquadrics) {
    const Eigen::Quaterniond q = sq.quaternion();
    list.push_back(
        {{"segment", sq.segment},
         {"a", vec(sq.a)},
         {"epsilon", json::array({sq.e1, sq.e2})},
         {"position", vec(sq.position)},
         {"orientation",
          {{"quaternion", json::array({q.x(), q.y(), q.z(), q.w()})}, {"euler", vec(sq.euler)}}},
         {"points", sq.points},
         {"residual", sq.residual},
         {"support", nd::floorSupportName(sq.support)}});
  }
  return list;
}

json timingsJson(const nd::Result& r, double detect_ms) {
  json timings = json::object();
  for (const auto& t : nd::stageTotals(r.timings)) timings[t.stage] = t.ms;
  timings["detect_total"] = detect_ms;
  return timings;
}

json reportJson(const nd::Result& r, const nd::Pipeline& pipeline, double reference_ms,
                double detect_ms, const Assumptions& as) {
  const bool checked_disappearances = as.disappearances_checked;
  json timings = timingsJson(r, detect_ms);
  timings["reference_model"] = reference_ms;
  json counts = json::object();
  for (const auto& [stage, n] : r.point_counts) counts[stage] = n;
  std::size_t novel = 0;
  for (bool b : r.novel_gaussian) novel += b;
  std::size_t newly_visible = 0, disappeared = 0;
  for (auto f : r.newly_visible) newly_visible += f != 0;
  for (int l : r.disappeared_labels) disappeared += l > 0;
  json segments = json::array();
  for (const auto& s : r.segments) {
    segments.push_back({{"id", s.id},
                        {"points", s.indices.size()},
                        {"centroid", vec(s.centroid)},
                        {"bbox_min", vec(s.bbox_min)},
                        {"bbox_max", vec(s.bbox_max)},
                        {"emd_contribution", s.emd_contribution},
                        {"gaussians", s.gaussians}});
  }
  const nd::AlignmentResult& a = r.alignment;
  const Eigen::Quaterniond aq(a.correction.rotation());
  const json alignment = {{"attempted", a.attempted},
                          {"applied", a.applied},
                          {"status", a.status},
                          {"translation", vec(Eigen::Vector3d(a.correction.translation()))},
                          {"quaternion", json::array({aq.x(), aq.y(), aq.z(), aq.w()})},
                          {"translation_m", a.translation_m},
                          {"rotation_deg", a.rotation_deg},
                          {"fitness_m", a.fitness_m},
                          {"inlier_fraction", a.inlier_fraction},
                          {"cost_reduction", a.cost_reduction},
                          {"samples", a.samples},
                          {"iterations", a.iterations},
                          {"degenerate_directions", a.degenerate_directions},
                          {"ms", a.ms}};
  return {{"timings_ms", timings},
          {"point_counts", counts},
          {"alignment", alignment},
          {"gaussians",
           {{"reference", pipeline.referenceGmm().size()},
            {"current", r.current_gmm.size()},
            {"novel", novel}}},
          {"emd_before", r.emd_before},
          {"emd_after", r.emd_after},
          {"num_segments", r.segments.size()},
          {"num_superquadrics", r.superquadrics.size()},
          {"segments", segments},
          {"newly_visible_points", newly_visible},
          {"disappeared_points", disappeared},
          {"num_disappeared_segments", r.disappeared_segments.size()},
          {"num_disappeared_superquadrics", r.disappeared_superquadrics.size()},
          {"disappearances_checked", checked_disappearances},
          {"visibility_checked", as.visibility_checked},
          {"sensor_origins",
           {{"reference", as.reference_sweeps > 1 ? json{{"position", nullptr},
                                                         {"from", as.reference_origin},
                                                         {"sweeps", as.reference_sweeps}}
                                                  : originJson(*as.reference, as.reference_origin)},
            {"current", originJson(*as.current, as.current_origin)}}},
          {"up", vec(r.up)},
          {"up_source", r.up_source},
          {"floor", r.floor_found ? json::array({r.floor[0], r.floor[1], r.floor[2], r.floor[3]})
                                  : json(nullptr)},
          {"tau_m", r.tau_m},
          {"overlap", r.overlap},
          {"compared", true},
          {"noise",
           {{"sigma_m", r.noise_sigma_m},
            {"model", r.noise_model.empty() ? json(nullptr) : json(r.noise_model)}}},
          {"reference_cache", cacheJson(as.cache)},
          {"warnings", r.warnings}};
}

}  // namespace cli
}  // namespace novelty_detection
