// evaluate: scores novelty labels against ground truth, for one scene or a whole suite.
//
//   evaluate --labels labels.txt --gt gt_labels.txt [--json out.json]
//   evaluate --suite SUITE_DIR --results RESULTS_DIR [--markdown table.md] [--csv table.csv]
//            [--json out.json]
//   evaluate --seed-scores SEED=scores.json [--seed-scores ...] [--markdown seeds.md]
//            [--json seeds.json]
//
// The third form summarises the suite mode's JSON of several suite seeds: per scene group
// the mean over the seeds and the worst seed (eval/seed_summary.h).
// For suites whose scenes carry a group and disappearance / newly-visible ground truth
// (simulate_scans), the suite mode also scores per scene group (viewpoint_evaluation.h).
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "novelty_detection/eval/evaluation.h"
#include "novelty_detection/eval/seed_summary.h"
#include "novelty_detection/eval/shape_evaluation.h"
#include "novelty_detection/eval/viewpoint_evaluation.h"
#include "novelty_detection/io/cloud_io.h"
#include "shape_report.h"
#include "tool_main.h"

namespace fs = std::filesystem;
using namespace novelty_detection;
using cli::shapeKindJson;
using cli::shapeKindMarkdown;
using cli::shapeObjectJson;

namespace {

const char* kUsage =
    "usage: evaluate --labels labels.txt --gt gt_labels.txt [--json out.json]\n"
    "       evaluate --suite SUITE_DIR --results RESULTS_DIR [--markdown table.md]\n"
    "                [--csv table.csv] [--json out.json]\n"
    "       evaluate --seed-scores SEED=scores.json [--seed-scores ...]\n"
    "                [--markdown seeds.md] [--json seeds.json]\n";

struct Options {
  std::string labels, gt, suite, results, json, markdown, csv;
  std::vector<std::pair<std::string, std::string>> seed_scores;  ///< (seed, scores.json)
};

Options parse(int argc, char** argv) {
  Options o;
  std::vector<std::string> a(argv + 1, argv + argc);
  for (std::size_t i = 0; i < a.size(); ++i) {
    const std::string& f = a[i];
    if (f == "--help" || f == "-h") {
      std::cout << kUsage;
      std::exit(0);
    }
    if (f == "--seed-scores") {
      if (i + 1 >= a.size() || a[i + 1].rfind("--", 0) == 0)
        throw std::invalid_argument("--seed-scores needs SEED=scores.json");
      const std::string v = a[++i];
      const std::size_t eq = v.find('=');
      if (eq == std::string::npos || eq == 0 || eq + 1 == v.size())
        throw std::invalid_argument("--seed-scores takes SEED=scores.json, got '" + v + "'");
      o.seed_scores.emplace_back(v.substr(0, eq), v.substr(eq + 1));
      continue;
    }
    std::string* target = f == "--labels"     ? &o.labels
                          : f == "--gt"       ? &o.gt
                          : f == "--suite"    ? &o.suite
                          : f == "--results"  ? &o.results
                          : f == "--json"     ? &o.json
                          : f == "--markdown" ? &o.markdown
                          : f == "--csv"      ? &o.csv
                                              : nullptr;
    if (!target) throw std::invalid_argument("unknown argument '" + f + "'");
    if (i + 1 >= a.size() || a[i + 1].rfind("--", 0) == 0)
      throw std::invalid_argument(f + " needs a value");
    *target = a[++i];
  }
  const bool single = !o.labels.empty() || !o.gt.empty();
  const bool suite = !o.suite.empty() || !o.results.empty();
  const bool seeds = !o.seed_scores.empty();
  if (int(single) + int(suite) + int(seeds) != 1)
    throw std::invalid_argument(
        "give either --labels and --gt, or --suite and --results, or --seed-scores");
  if (seeds && !o.csv.empty()) throw std::invalid_argument("--csv is for --suite");
  if (single && (o.labels.empty() || o.gt.empty()))
    throw std::invalid_argument("--labels and --gt go together");
  if (suite && (o.suite.empty() || o.results.empty()))
    throw std::invalid_argument("--suite and --results go together");
  if (single && (!o.markdown.empty() || !o.csv.empty()))
    throw std::invalid_argument("--markdown and --csv are for --suite");
  return o;
}

void writeText(const std::string& path, const std::string& text) {
  std::ofstream f(path);
  f << text;
  if (!f.flush()) throw std::runtime_error(path + ": cannot write");
}

nlohmann::json toJson(const SceneScore& s) {
  nlohmann::json objects = nlohmann::json::array(), segments = nlohmann::json::array();
  for (const auto& o : s.objects)
    objects.push_back({{"id", o.id},
                       {"points", o.points},
                       {"best_segment", o.best_segment},
                       {"best_iou", o.best_iou},
                       {"found", o.found}});
  for (const auto& g : s.segments)
    segments.push_back({{"id", g.id},
                        {"points", g.points},
                        {"novel_points", g.novel_points},
                        {"matched_object", g.matched_object},
                        {"best_iou", g.best_iou},
                        {"false_segment", g.false_segment}});
  return {{"points", s.points},
          {"tp", s.tp},
          {"fp", s.fp},
          {"fn", s.fn},
          {"tn", s.tn},
          {"precision", s.precision},
          {"recall", s.recall},
          {"f1", s.f1},
          {"iou", s.iou},
          {"objects_found", s.objects_found},
          {"objects_total", s.objects.size()},
          {"false_segments", s.false_segments},
          {"fragment_segments", s.fragment_segments},
          {"largest_false_segment", s.largest_false_segment},
          {"success", s.success},
          {"objects", objects},
          {"segments", segments}};
}

int evaluateOne(const Options& o) {
  const std::vector<int> gt = readLabelFile(o.gt);
  const std::vector<int> labels = readLabelFile(o.labels, static_cast<long>(gt.size()));
  const SceneScore s = scoreLabels(labels, gt);
  std::printf("points %zu  TP %zu  FP %zu  FN %zu  TN %zu\n", s.points, s.tp, s.fp, s.fn, s.tn);
  std::printf("precision %.4f  recall %.4f  F1 %.4f  IoU %.4f\n", s.precision, s.recall, s.f1,
              s.iou);
  for (const auto& obj : s.objects)
    std::printf("object %d (%zu points): %s, best segment %d with IoU %.3f\n", obj.id, obj.points,
                obj.found ? "found" : "missed", obj.best_segment, obj.best_iou);
  for (const auto& g : s.segments)
    if (g.matched_object == 0)
      std::printf("segment %d (%zu points): %s\n", g.id, g.points,
                  g.false_segment ? "false segment" : "fragment of a changed object");
  std::printf("objects found %d/%zu, false segments %d (largest %zu points), success: %s\n",
              s.objects_found, s.objects.size(), s.false_segments, s.largest_false_segment,
              s.success ? "yes" : "no");
  if (!o.json.empty()) writeText(o.json, toJson(s).dump(2) + "\n");
  return 0;
}

int evaluateSuite(const Options& o) {
  if (!fs::is_directory(o.suite)) throw std::runtime_error(o.suite + ": not a directory");
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(o.suite))
    if (e.is_directory() && e.path().filename().string().rfind("scene_", 0) == 0 &&
        fs::exists(e.path() / "gt_labels.txt"))
      names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  if (names.empty())
    throw std::runtime_error(o.suite + ": no scene_*/gt_labels.txt (run simulate_scans --suite)");

  std::vector<SuiteEntry> entries;
  std::vector<ViewpointSceneScore> viewpoint;
  nlohmann::json scenes = nlohmann::json::array();
  int shape_objects = 0;
  double shape_sum_m = 0.0;
  nlohmann::json shape_json = nlohmann::json::object();
  std::vector<ObjectShapeError> shape_errors;  // per found object, over the suite
  for (const auto& name : names) {
    SuiteEntry e;
    e.name = name;
    nlohmann::json scene_shapes = nlohmann::json::array();
    const std::vector<int> gt = readLabelFile((fs::path(o.suite) / name / "gt_labels.txt"));
    const fs::path labels_path = fs::path(o.results) / name / "labels.txt";
    if (!fs::exists(labels_path)) {
      e.note = "missing labels.txt";
    } else {
      try {
        e.score = scoreLabels(readLabelFile(labels_path, static_cast<long>(gt.size())), gt);
        e.has_result = true;
        // Shapes (superquadric surface error) when both files are there.
        const fs::path sq_path = fs::path(o.results) / name / "superquadrics.json";
        const fs::path cur_path = fs::path(o.suite) / name / "cur.pcd";
        if (fs::exists(sq_path) && fs::exists(cur_path)) {
          const Cloud cur = loadCloud(cur_path.string());
          const std::vector<Superquadric> fitted = readSuperquadricsJson(sq_path);
          const ShapeScore shape = scoreShapes(cur, gt, e.score, fitted);
          shape_objects += shape.objects;
          shape_sum_m += shape.mean_surface_distance_m * shape.objects;
          if (shape.objects > 0) shape_json[name] = shape.mean_surface_distance_m;
          const fs::path scene_json = fs::path(o.suite) / name / "scene.json";
          if (fs::exists(scene_json)) {
            for (const auto& err : scoreShapesByObject(cur, gt, e.score, fitted,
                                                       readTrueShapes(scene_json.string()))) {
              shape_errors.push_back(err);
              scene_shapes.push_back(shapeObjectJson(err));
            }
          }
        }
      } catch (const std::exception& ex) {
        e.note = ex.what();
        std::cerr << "evaluate: " << name << " counted as failed: " << ex.what() << "\n";
      }
    }
    if (!e.has_result) e.score = scoreLabels(std::vector<int>(gt.size(), 0), gt);
    if (!e.has_result) e.score.success = false;
    nlohmann::json j = toJson(e.score);
    j["scene"] = name;
    j["has_result"] = e.has_result;
    j["note"] = e.note;
    j["shapes"] = scene_shapes;
    const ViewpointSceneScore v =
        scoreViewpointScene(name, (fs::path(o.suite) / name).string(),
                            (fs::path(o.results) / name).string(), e.score, e.has_result);
    j["group"] = v.group;
    j["removed_objects"] = v.removed_ids;
    j["removed_found"] = v.removed_found;
    j["has_disappeared"] = v.has_disappeared;
    j["disappeared_note"] = v.disappeared_note;
    j["disappearance"] = {{"precision", v.disappearance.precision},
                          {"recall", v.disappearance.recall},
                          {"f1", v.disappearance.f1},
                          {"objects", toJson(v.disappearance)["objects"]}};
    j["newly_visible_points"] = v.newly_visible_points;
    j["newly_visible_novel"] = v.newly_visible_novel;
    j["newly_visible_reported"] = v.newly_visible_reported;
    viewpoint.push_back(v);
    scenes.push_back(j);
    entries.push_back(e);
  }
  const SuiteSummary m = summarizeSuite(entries);
  std::string md = suiteMarkdown(entries, m);
  if (shape_objects > 0) {
    std::ostringstream line;
    line << "\nSuperquadric surface error: mean " << std::fixed << std::setprecision(1)
         << 1000.0 * shape_sum_m / shape_objects << " mm from the true points of the "
         << shape_objects << " found objects to their segment's superquadrics.\n";
    md += line.str();
  }
  const std::vector<KindShapeError> shape_kinds = summarizeShapesByKind(shape_errors);
  if (!shape_kinds.empty()) md += shapeKindMarkdown(shape_kinds);
  const std::vector<GroupSummary> groups = summarizeGroups(viewpoint);
  int missing_disappeared = 0;
  for (const auto& v : viewpoint)
    missing_disappeared += !v.removed_ids.empty() && !v.has_disappeared;
  if (missing_disappeared > 0)
    std::cerr << "evaluate: " << missing_disappeared
              << " removal scene(s) without a readable disappeared_labels.txt: their "
                 "disappearances count as not found\n";
  md +=
      "\nPer scene group (disappearances: removal scenes whose removed objects were all "
      "found; newly visible: ground-truth newly visible points labelled novel):\n\n" +
      groupsMarkdown(groups);
  const std::vector<KindSummary> kinds = summarizeKinds(viewpoint);
  if (!kinds.empty())
    md += "\nPer object type (found: a segment with IoU >= 0.5):\n\n" + kindsMarkdown(kinds);
  std::cout << md;
  if (!o.markdown.empty()) writeText(o.markdown, md);
  nlohmann::json kinds_json = nlohmann::json::array();
  for (const KindSummary& k : kinds)
    kinds_json.push_back({{"type", k.type},
                          {"objects", k.objects},
                          {"found", k.found},
                          {"scenes", k.scenes},
                          {"scenes_found", k.scenes_found}});
  nlohmann::json groups_json = nlohmann::json::array();
  for (const auto& g : groups)
    groups_json.push_back({{"group", g.group},
                           {"scenes", g.scenes},
                           {"successes", g.successes},
                           {"success_rate", g.scenes ? double(g.successes) / g.scenes : 0.0},
                           {"appearance_scenes", g.appearance_scenes},
                           {"mean_f1", g.mean_f1},
                           {"removal_scenes", g.removal_scenes},
                           {"removal_scenes_found", g.removal_scenes_found},
                           {"removal_scenes_without_result", g.removal_scenes_without_result},
                           {"removed_objects", g.removed_objects},
                           {"removed_found", g.removed_found},
                           {"newly_visible_points", g.newly_visible_points},
                           {"newly_visible_novel", g.newly_visible_novel},
                           {"newly_visible_novel_fraction", g.newly_visible_novel_fraction}});
  if (!o.csv.empty()) writeText(o.csv, suiteCsv(entries));
  if (!o.json.empty()) {
    const nlohmann::json j = {
        {"scenes", scenes},
        {"groups", groups_json},
        {"kinds", kinds_json},
        {"summary",
         {{"scenes", m.scenes},
          {"successes", m.successes},
          {"missing", m.missing},
          {"success_rate", m.success_rate},
          {"mean_precision", m.mean_precision},
          {"mean_recall", m.mean_recall},
          {"mean_f1", m.mean_f1},
          {"mean_iou", m.mean_iou},
          {"objects_found", m.objects_found},
          {"objects_total", m.objects_total},
          {"false_segments", m.false_segments},
          {"shape_objects", shape_objects},
          {"mean_shape_error_m", shape_objects > 0 ? shape_sum_m / shape_objects : 0.0},
          {"shape_error_m_per_scene", shape_json},
          {"shapes_by_kind", shapeKindJson(shape_kinds)}}}};
    writeText(o.json, j.dump(2) + "\n");
  }
  return 0;
}

int summarizeSeedScores(const Options& o) {
  const SeedSummary summary = summarizeSeeds(o.seed_scores);
  const std::string md = seedSummaryMarkdown(summary);
  std::cout << md;
  if (!o.markdown.empty()) writeText(o.markdown, md);
  if (!o.json.empty()) writeText(o.json, seedSummaryJson(summary));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return novelty_detection::runTool("evaluate", " (see --help)", argc, argv, parse,
                                    [](const Options& o) {
                                      if (!o.seed_scores.empty()) return summarizeSeedScores(o);
                                      return o.suite.empty() ? evaluateOne(o) : evaluateSuite(o);
                                    });
}
