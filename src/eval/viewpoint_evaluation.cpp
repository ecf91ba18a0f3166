#include "novelty_detection/eval/viewpoint_evaluation.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>
#include <stdexcept>

namespace fs = std::filesystem;

namespace novelty_detection {
namespace {

std::string fmt(double v, int decimals) {
  char b[32];
  std::snprintf(b, sizeof(b), "%.*f", decimals, v);
  return b;
}

std::string percent(int num, int den) {
  if (den == 0) return "-";
  return fmt(100.0 * num / den, 0) + " % (" + std::to_string(num) + "/" + std::to_string(den) + ")";
}

}  // namespace

ViewpointSceneScore scoreViewpointScene(const std::string& name, const std::string& scene_dir,
                                        const std::string& result_dir, const SceneScore& appearance,
                                        bool has_result, const EvaluationOptions& options) {
  ViewpointSceneScore v;
  v.name = name;
  v.has_result = has_result;
  v.appearance = appearance;
  v.has_appearances = appearance.tp + appearance.fn > 0;
  const fs::path scene(scene_dir), result(result_dir);

  const fs::path json_path = scene / "scene.json";
  if (fs::exists(json_path)) {
    std::ifstream f(json_path);
    nlohmann::json j;
    try {
      f >> j;
    } catch (const std::exception& e) {
      throw std::runtime_error(json_path.string() + ": not valid JSON (" + e.what() + ")");
    }
    if (j.contains("group")) v.group = j["group"].get<std::string>();
    if (j.contains("objects") && j["objects"].is_array())
      for (const auto& o : j["objects"])
        if (o.contains("id") && o.contains("type"))
          v.object_types.emplace_back(o["id"].get<int>(), o["type"].get<std::string>());
    if (j.contains("removed_objects"))
      for (const auto& id : j["removed_objects"]) v.removed_ids.push_back(id.get<int>());
  }

  const fs::path gt_disappeared = scene / "gt_disappeared_labels.txt";
  if (fs::exists(gt_disappeared)) {
    const std::vector<int> truth = readLabelFile(gt_disappeared.string());
    const fs::path pred_path = result / "disappeared_labels.txt";
    std::vector<int> predicted(truth.size(), 0);
    if (!fs::exists(pred_path)) {
      v.disappeared_note = "missing disappeared_labels.txt";
    } else {
      try {
        predicted = readLabelFile(pred_path.string(), static_cast<long>(truth.size()));
        v.has_disappeared = true;
      } catch (const std::exception& e) {
        v.disappeared_note = e.what();
      }
    }
    v.disappearance = scoreLabels(predicted, truth, options);
    if (!v.has_disappeared) {
      // Nothing was claimed: no removed object counts as found.
      for (auto& o : v.disappearance.objects) o.found = false;
      v.disappearance.objects_found = 0;
      v.disappearance.success = false;
    }
    for (int id : v.removed_ids)
      for (const auto& o : v.disappearance.objects)
        if (o.id == id && o.found) ++v.removed_found;
  } else if (!v.removed_ids.empty()) {
    v.disappeared_note = "missing gt_disappeared_labels.txt";
  }

  const fs::path gt_nv = scene / "gt_newly_visible.txt";
  if (fs::exists(gt_nv)) {
    const std::vector<int> truth = readLabelFile(gt_nv.string());
    v.has_newly_visible_truth = true;
    std::vector<int> labels;
    const fs::path labels_path = result / "labels.txt";
    if (has_result && fs::exists(labels_path))
      labels = readLabelFile(labels_path.string(), static_cast<long>(truth.size()));
    std::vector<int> reported;
    const fs::path nv_path = result / "newly_visible.txt";
    if (fs::exists(nv_path)) {
      try {
        reported = readLabelFile(nv_path.string(), static_cast<long>(truth.size()));
        v.has_newly_visible_result = true;
      } catch (const std::exception&) {
        reported.clear();
      }
    }
    for (std::size_t i = 0; i < truth.size(); ++i) {
      if (truth[i] == 0) continue;
      ++v.newly_visible_points;
      if (!labels.empty() && labels[i] > 0) ++v.newly_visible_novel;
      if (!reported.empty() && reported[i] > 0) ++v.newly_visible_reported;
    }
  }
  return v;
}

std::vector<GroupSummary> summarizeGroups(const std::vector<ViewpointSceneScore>& scenes) {
  std::map<std::string, GroupSummary> by_name;
  GroupSummary all;
  all.group = "all";
  auto add = [](GroupSummary& g, const ViewpointSceneScore& s) {
    ++g.scenes;
    g.successes += s.has_result && s.appearance.success;
    if (s.has_appearances) {
      ++g.appearance_scenes;
      if (s.has_result) g.mean_f1 += s.appearance.f1;
    }
    if (!s.removed_ids.empty()) {
      ++g.removal_scenes;
      g.removal_scenes_found += s.removed_found == static_cast<int>(s.removed_ids.size());
      g.removal_scenes_without_result += !s.has_disappeared;
    }
    g.removed_objects += static_cast<int>(s.removed_ids.size());
    g.removed_found += s.removed_found;
    g.newly_visible_points += s.newly_visible_points;
    g.newly_visible_novel += s.newly_visible_novel;
  };
  for (const auto& s : scenes) {
    GroupSummary& g = by_name[s.group];
    g.group = s.group;
    add(g, s);
    add(all, s);
  }
  std::vector<GroupSummary> out;
  for (const char* name : {"same_pose", "pose_offset", "localisation_error"}) {
    const auto it = by_name.find(name);
    if (it == by_name.end()) continue;
    out.push_back(it->second);
    by_name.erase(it);
  }
  for (const auto& [name, g] : by_name) out.push_back(g);
  out.push_back(all);
  for (auto& g : out) {
    if (g.appearance_scenes > 0) g.mean_f1 /= g.appearance_scenes;
    g.newly_visible_novel_fraction =
        g.newly_visible_points > 0
            ? static_cast<double>(g.newly_visible_novel) / g.newly_visible_points
            : 0.0;
  }
  return out;
}

std::string groupsMarkdown(const std::vector<GroupSummary>& groups) {
  std::ostringstream o;
  o << "| group | scenes | scene success | mean point F1 (appearances) | disappearances found "
       "| newly visible points labelled novel |\n|---|---:|---:|---:|---:|---:|\n";
  for (const auto& g : groups) {
    o << "| " << g.group << " | " << g.scenes << " | " << percent(g.successes, g.scenes) << " | "
      << (g.appearance_scenes ? fmt(g.mean_f1, 3) : std::string("-")) << " | "
      << percent(g.removal_scenes_found, g.removal_scenes);
    if (g.removal_scenes_without_result > 0)
      o << " [" << g.removal_scenes_without_result << " without disappeared_labels.txt]";
    o << " | ";
    if (g.newly_visible_points == 0)
      o << "-";
    else
      o << fmt(100.0 * g.newly_visible_novel_fraction, 1) << " % (" << g.newly_visible_novel << "/"
        << g.newly_visible_points << ")";
    o << " |\n";
  }
  return o.str();
}

std::vector<KindSummary> summarizeKinds(const std::vector<ViewpointSceneScore>& scenes) {
  std::map<std::string, KindSummary> by_type;
  for (const ViewpointSceneScore& s : scenes) {
    std::map<std::string, bool> all_found;
    for (const auto& [id, type] : s.object_types) {
      const auto it = std::find_if(s.appearance.objects.begin(), s.appearance.objects.end(),
                                   [id = id](const ObjectScore& o) { return o.id == id; });
      if (it == s.appearance.objects.end() || it->points == 0) continue;  // no current points
      KindSummary& k = by_type[type];
      k.type = type;
      ++k.objects;
      const bool found = s.has_result && it->found;
      k.found += found;
      auto [slot, fresh] = all_found.emplace(type, found);
      if (!fresh) slot->second = slot->second && found;
    }
    for (const auto& [type, found] : all_found) {
      ++by_type[type].scenes;
      by_type[type].scenes_found += found;
    }
  }
  std::vector<KindSummary> out;
  for (auto& [type, k] : by_type) out.push_back(k);
  return out;
}

std::string kindsMarkdown(const std::vector<KindSummary>& kinds) {
  std::ostringstream md;
  md << "| object type | objects found | scenes with all found |\n|---|---:|---:|\n";
  for (const KindSummary& k : kinds)
    md << "| " << k.type << " | " << percent(k.found, k.objects) << " | "
       << percent(k.scenes_found, k.scenes) << " |\n";
  return md.str();
}

}  // namespace novelty_detection
