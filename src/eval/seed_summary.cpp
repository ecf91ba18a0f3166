#include "novelty_detection/eval/seed_summary.h"

#include "novelty_detection/eval/shape_evaluation.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <set>
#include <stdexcept>

namespace novelty_detection {
namespace {

nlohmann::json readJson(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read scores file '" + path + "'");
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error("scores file '" + path + "' is not valid JSON: " + e.what());
  }
}

template <class T>
T field(const nlohmann::json& j, const char* key, const std::string& path) {
  if (!j.is_object() || !j.contains(key))
    throw std::runtime_error("scores file '" + path + "' has no '" + key + "'");
  try {
    return j.at(key).get<T>();
  } catch (const nlohmann::json::exception&) {
    throw std::runtime_error("scores file '" + path + "': '" + key + "' has the wrong type");
  }
}

std::string percent(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f %%", 100.0 * v);
  return b;
}

std::string fixedN(double v, int digits) {
  char b[32];
  std::snprintf(b, sizeof b, "%.*f", digits, v);
  return b;
}
std::string fixed1(double v) { return fixedN(v, 1); }
std::string fixed2(double v) { return fixedN(v, 2); }
std::string fixed3(double v) { return fixedN(v, 3); }

}  // namespace

SeedSummary summarizeSeeds(const std::vector<std::pair<std::string, std::string>>& seed_scores) {
  if (seed_scores.empty()) throw std::invalid_argument("no seeds to summarise");
  SeedSummary out;
  std::set<std::string> seen;
  struct Row {
    std::string seed;
    int scenes;
    double success, f1;
  };
  std::vector<std::pair<std::string, std::vector<Row>>> rows;  // per group
  for (const auto& [seed, path] : seed_scores) {
    if (!seen.insert(seed).second) throw std::invalid_argument("seed '" + seed + "' given twice");
    out.seeds.push_back(seed);
    const nlohmann::json j = readJson(path);
    const auto groups = field<nlohmann::json>(j, "groups", path);
    const auto summary = field<nlohmann::json>(j, "summary", path);
    if (!groups.is_array())
      throw std::runtime_error("scores file '" + path + "': 'groups' is not a list");
    for (const auto& g : groups) {
      const std::string name = field<std::string>(g, "group", path);
      auto it =
          std::find_if(rows.begin(), rows.end(), [&](const auto& r) { return r.first == name; });
      if (it == rows.end()) it = rows.insert(rows.end(), {name, {}});
      it->second.push_back({seed, field<int>(g, "scenes", path),
                            field<double>(g, "success_rate", path),
                            field<double>(g, "mean_f1", path)});
    }
    if (j.contains("kinds") && j["kinds"].is_array()) {
      for (const auto& k : j["kinds"]) {
        const std::string type = field<std::string>(k, "type", path);
        const int objects = field<int>(k, "objects", path), found = field<int>(k, "found", path);
        auto it = std::find_if(out.kinds.begin(), out.kinds.end(),
                               [&](const SeedKindSummary& x) { return x.type == type; });
        if (it == out.kinds.end()) {
          it = out.kinds.insert(out.kinds.end(), SeedKindSummary{});
          it->type = type;
          it->worst_rate = 2.0;
        }
        it->objects += objects;
        it->found += found;
        const double rate = objects > 0 ? static_cast<double>(found) / objects : 1.0;
        if (rate < it->worst_rate) it->worst_rate = rate, it->worst_seed = seed;
      }
    }
    if (summary.contains("shapes_by_kind") && summary["shapes_by_kind"].is_array()) {
      for (const auto& k : summary["shapes_by_kind"]) {
        const std::string type = field<std::string>(k, "type", path);
        auto it = std::find_if(out.shapes.begin(), out.shapes.end(),
                               [&](const SeedShapeSummary& x) { return x.type == type; });
        if (it == out.shapes.end()) {
          it = out.shapes.insert(out.shapes.end(), SeedShapeSummary{});
          it->type = type;
        }
        // Sums here, means below.
        const int objects = field<int>(k, "objects", path);
        const int axis_objects = k.value("semi_axis_objects", 0);
        it->objects += objects;
        it->surface_m += objects * field<double>(k, "surface_error_m", path);
        it->floor_m += objects * field<double>(k, "floor_m", path);
        it->axis_objects += axis_objects;
        if (axis_objects > 0)
          it->semi_axis_m += axis_objects * field<double>(k, "semi_axis_error_m", path);
        // The well-seen figures (files written before they were kept hold none).
        const int seen_axis = k.value("seen_semi_axis_objects", 0);
        it->seen_axis_objects += seen_axis;
        if (seen_axis > 0)
          it->seen_semi_axis_m += seen_axis * field<double>(k, "seen_semi_axis_error_m", path);
        it->seen_objects += k.value("seen_objects", 0);
        it->seen_parts_3_to_7 += k.value("seen_parts_3_to_7", 0);
      }
    }
    out.objects_found += field<long>(summary, "objects_found", path);
    out.objects_total += field<long>(summary, "objects_total", path);
    out.false_segments += field<long>(summary, "false_segments", path);
  }
  for (SeedShapeSummary& k : out.shapes) {
    if (k.objects > 0) k.surface_m /= k.objects, k.floor_m /= k.objects;
    if (k.axis_objects > 0) k.semi_axis_m /= k.axis_objects;
    if (k.seen_axis_objects > 0) k.seen_semi_axis_m /= k.seen_axis_objects;
  }
  // "all" last.
  std::stable_partition(rows.begin(), rows.end(), [](const auto& r) { return r.first != "all"; });
  for (const auto& [name, list] : rows) {
    SeedGroupSummary s;
    s.group = name;
    s.seeds = static_cast<int>(list.size());
    const Row* worst = &list.front();
    s.min_f1 = list.front().f1;
    for (const Row& r : list) {
      s.scenes += r.scenes;
      s.mean_success += r.success / s.seeds;
      s.mean_f1 += r.f1 / s.seeds;
      s.min_f1 = std::min(s.min_f1, r.f1);
      if (r.success < worst->success || (r.success == worst->success && r.f1 < worst->f1))
        worst = &r;
    }
    s.worst_seed = worst->seed;
    s.worst_success = worst->success;
    s.worst_f1 = worst->f1;
    out.groups.push_back(s);
  }
  return out;
}

std::string seedSummaryMarkdown(const SeedSummary& summary) {
  std::string seeds;
  for (const std::string& s : summary.seeds) seeds += (seeds.empty() ? "" : ", ") + s;
  std::string md =
      "| scene group | seeds | scenes | mean success | worst seed: success, F1 | mean F1 | lowest "
      "F1 |\n"
      "|---|---:|---:|---:|---|---:|---:|\n";
  for (const SeedGroupSummary& g : summary.groups) {
    md += "| " + g.group + " | " + std::to_string(g.seeds) + " | " + std::to_string(g.scenes) +
          " | " + percent(g.mean_success) + " | " + g.worst_seed + ": " + percent(g.worst_success) +
          ", " + fixed3(g.worst_f1) + " | " + fixed3(g.mean_f1) + " | " + fixed3(g.min_f1) + " |\n";
  }
  md += "\nSuite seeds " + seeds + ": objects found " + std::to_string(summary.objects_found) +
        "/" + std::to_string(summary.objects_total) + ", false segments " +
        std::to_string(summary.false_segments) + ".\n";
  if (!summary.kinds.empty()) {
    md += "\n| object type | found over the seeds | worst seed: found |\n|---|---:|---|\n";
    for (const SeedKindSummary& k : summary.kinds) {
      const double rate = k.objects > 0 ? static_cast<double>(k.found) / k.objects : 0.0;
      md += "| " + k.type + " | " + percent(rate) + " (" + std::to_string(k.found) + "/" +
            std::to_string(k.objects) + ") | " + k.worst_seed + ": " + percent(k.worst_rate) +
            " |\n";
    }
  }
  if (!summary.shapes.empty()) {
    md +=
        "\n| object type | objects | surface error | floor | error / floor | semi-axis error "
        "(one-part fits) | seen with >= " +
        std::to_string(kWellSeenPoints) + " points |\n|---|---:|---:|---:|---:|---:|---:|\n";
    for (const SeedShapeSummary& k : summary.shapes) {
      const auto mm = [](double m) { return fixed1(1000.0 * m) + " mm"; };
      const auto axis = [&mm](int objects, double error_m) {
        return objects > 0 ? mm(error_m) + " (" + std::to_string(objects) + ")" : std::string("-");
      };
      md += "| " + k.type + " | " + std::to_string(k.objects) + " | " + mm(k.surface_m) + " | " +
            mm(k.floor_m) + " | " + (k.floor_m > 0.0 ? fixed2(k.surface_m / k.floor_m) : "-") +
            " | " + axis(k.axis_objects, k.semi_axis_m) + " | " +
            axis(k.seen_axis_objects, k.seen_semi_axis_m) + " |\n";
    }
    for (const SeedShapeSummary& k : summary.shapes) {
      if (k.type != "person" || k.seen_objects == 0) continue;
      md += "\nPeople seen with at least " + std::to_string(kWellSeenPoints) +
            " points: " + std::to_string(k.seen_parts_3_to_7) + " of " +
            std::to_string(k.seen_objects) + " with 3 to 7 parts.\n";
    }
  }
  return md;
}

std::string seedSummaryJson(const SeedSummary& summary) {
  nlohmann::json j;
  j["seeds"] = summary.seeds;
  j["objects_found"] = summary.objects_found;
  j["objects_total"] = summary.objects_total;
  j["false_segments"] = summary.false_segments;
  j["groups"] = nlohmann::json::array();
  for (const SeedGroupSummary& g : summary.groups) {
    j["groups"].push_back({{"group", g.group},
                           {"seeds", g.seeds},
                           {"scenes", g.scenes},
                           {"mean_success", g.mean_success},
                           {"mean_f1", g.mean_f1},
                           {"worst_seed", g.worst_seed},
                           {"worst_success", g.worst_success},
                           {"worst_f1", g.worst_f1},
                           {"min_f1", g.min_f1}});
  }
  j["kinds"] = nlohmann::json::array();
  for (const SeedKindSummary& k : summary.kinds)
    j["kinds"].push_back({{"type", k.type},
                          {"objects", k.objects},
                          {"found", k.found},
                          {"worst_seed", k.worst_seed},
                          {"worst_rate", k.worst_rate}});
  j["shapes_by_kind"] = nlohmann::json::array();
  for (const SeedShapeSummary& k : summary.shapes)
    j["shapes_by_kind"].push_back({{"type", k.type},
                                   {"objects", k.objects},
                                   {"surface_error_m", k.surface_m},
                                   {"floor_m", k.floor_m},
                                   {"semi_axis_objects", k.axis_objects},
                                   {"semi_axis_error_m", k.semi_axis_m},
                                   {"seen_semi_axis_objects", k.seen_axis_objects},
                                   {"seen_semi_axis_error_m", k.seen_semi_axis_m},
                                   {"seen_objects", k.seen_objects},
                                   {"seen_parts_3_to_7", k.seen_parts_3_to_7}});
  return j.dump(2) + "\n";
}

}  // namespace novelty_detection
