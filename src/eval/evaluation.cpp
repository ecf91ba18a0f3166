#include "novelty_detection/eval/evaluation.h"

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace novelty_detection {
namespace {

// Ratio with the edge-case rule of the header: 0/0 is 1 when nothing was to be found and
// nothing claimed, else 0.
double ratio(std::size_t num, std::size_t den, bool both_empty) {
  if (den == 0) return both_empty ? 1.0 : 0.0;
  return static_cast<double>(num) / static_cast<double>(den);
}

std::string fmt(double v, int decimals = 3) {
  char b[32];
  std::snprintf(b, sizeof(b), "%.*f", decimals, v);
  return b;
}

}  // namespace

SceneScore scoreLabels(const std::vector<int>& predicted, const std::vector<int>& truth,
                       const EvaluationOptions& options) {
  if (predicted.size() != truth.size())
    throw std::invalid_argument("predicted labels have " + std::to_string(predicted.size()) +
                                " entries but the ground truth has " +
                                std::to_string(truth.size()));
  if (!(options.match_iou > 0 && options.match_iou <= 1) ||
      !(options.false_segment_fraction > 0 && options.false_segment_fraction <= 1))
    throw std::invalid_argument("evaluation options must lie in (0, 1]");

  SceneScore s;
  s.points = truth.size();
  std::map<int, std::size_t> seg_size, seg_novel, obj_size;
  std::map<std::pair<int, int>, std::size_t> overlap;  // (segment, object) -> points
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const int p = predicted[i], t = truth[i];
    if (p < 0 || t < 0) throw std::invalid_argument("negative label at index " + std::to_string(i));
    if (p > 0) ++seg_size[p];
    if (t > 0) ++obj_size[t];
    if (p > 0 && t > 0) {
      ++seg_novel[p];
      ++overlap[{p, t}];
      ++s.tp;
    } else if (p > 0) {
      ++s.fp;
    } else if (t > 0) {
      ++s.fn;
    } else {
      ++s.tn;
    }
  }
  const bool pred_empty = s.tp + s.fp == 0, truth_empty = s.tp + s.fn == 0;
  const bool both_empty = pred_empty && truth_empty;
  s.precision = ratio(s.tp, s.tp + s.fp, both_empty);
  s.recall = ratio(s.tp, s.tp + s.fn, both_empty);
  s.f1 = s.precision + s.recall > 0 ? 2 * s.precision * s.recall / (s.precision + s.recall) : 0.0;
  s.iou = ratio(s.tp, s.tp + s.fp + s.fn, both_empty);

  auto iouOf = [&](int seg, int obj) {
    const auto it = overlap.find({seg, obj});
    if (it == overlap.end()) return 0.0;
    const double inter = static_cast<double>(it->second);
    return inter / (static_cast<double>(seg_size[seg] + obj_size[obj]) - inter);
  };

  for (const auto& [id, n] : obj_size) {
    ObjectScore o;
    o.id = id;
    o.points = n;
    for (const auto& [seg, m] : seg_size) {
      (void)m;
      const double iou = iouOf(seg, id);
      if (iou > o.best_iou) {
        o.best_iou = iou;
        o.best_segment = seg;
      }
    }
    o.found = o.best_iou >= options.match_iou;
    s.objects_found += o.found;
    s.objects.push_back(o);
  }
  for (const auto& [id, n] : seg_size) {
    SegmentScore g;
    g.id = id;
    g.points = n;
    g.novel_points = seg_novel.count(id) ? seg_novel[id] : 0;
    for (const auto& [obj, m] : obj_size) {
      (void)m;
      const double iou = iouOf(id, obj);
      if (iou > g.best_iou) g.best_iou = iou;
      if (iou >= options.match_iou) g.matched_object = obj;
    }
    if (g.matched_object == 0) {
      if (2 * g.novel_points > g.points) {
        ++s.fragment_segments;
      } else {
        g.false_segment = true;
        ++s.false_segments;
        s.largest_false_segment = std::max(s.largest_false_segment, g.points);
      }
    }
    s.segments.push_back(g);
  }
  const double limit = options.false_segment_fraction * static_cast<double>(s.points);
  s.success = s.objects_found == static_cast<int>(s.objects.size()) &&
              static_cast<double>(s.largest_false_segment) <= limit;
  return s;
}

std::vector<int> readLabelFile(const std::string& path, long expected_count) {
  std::ifstream f(path);
  if (!f) throw std::runtime_error(path + ": cannot open label file");
  std::vector<int> labels;
  std::string line, token;
  long line_no = 0;
  while (std::getline(f, line)) {
    ++line_no;
    std::istringstream ss(line);
    while (ss >> token) {
      int v = 0;
      const auto r = std::from_chars(token.data(), token.data() + token.size(), v);
      if (r.ec != std::errc() || r.ptr != token.data() + token.size())
        throw std::runtime_error(path + ":" + std::to_string(line_no) + ": '" + token +
                                 "' is not an integer label");
      if (v < 0)
        throw std::runtime_error(path + ":" + std::to_string(line_no) + ": negative label " +
                                 token);
      labels.push_back(v);
    }
  }
  if (f.bad()) throw std::runtime_error(path + ": read error");
  if (expected_count >= 0 && static_cast<long>(labels.size()) != expected_count)
    throw std::runtime_error(path + ": " + std::to_string(labels.size()) + " labels, expected " +
                             std::to_string(expected_count) + " (one per point)");
  return labels;
}

void writeLabelFile(const std::string& path, const std::vector<int>& labels) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp);
    for (int l : labels) f << l << '\n';
    if (!f.flush()) throw std::runtime_error(tmp + ": cannot write");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0)
    throw std::runtime_error(path + ": cannot rename the temporary file into place");
}

SuiteSummary summarizeSuite(const std::vector<SuiteEntry>& entries) {
  SuiteSummary m;
  m.scenes = static_cast<int>(entries.size());
  for (const auto& e : entries) {
    m.objects_total += static_cast<int>(e.score.objects.size());
    if (!e.has_result) {
      ++m.missing;
      continue;
    }
    m.successes += e.score.success;
    m.mean_precision += e.score.precision;
    m.mean_recall += e.score.recall;
    m.mean_f1 += e.score.f1;
    m.mean_iou += e.score.iou;
    m.objects_found += e.score.objects_found;
    m.false_segments += e.score.false_segments;
  }
  if (m.scenes > 0) {
    const double n = m.scenes;
    m.success_rate = m.successes / n;
    m.mean_precision /= n;
    m.mean_recall /= n;
    m.mean_f1 /= n;
    m.mean_iou /= n;
  }
  return m;
}

std::string suiteMarkdown(const std::vector<SuiteEntry>& entries, const SuiteSummary& m) {
  std::ostringstream o;
  o << "| scene | points | objects found | false segments | precision | recall | F1 | IoU | "
       "success |\n|---|---:|---:|---:|---:|---:|---:|---:|---|\n";
  for (const auto& e : entries) {
    const SceneScore& s = e.score;
    o << "| " << e.name << " | " << s.points << " | ";
    if (!e.has_result) {
      o << "0/" << s.objects.size() << " | - | - | - | - | - | no (" << e.note << ") |\n";
      continue;
    }
    o << s.objects_found << "/" << s.objects.size() << " | " << s.false_segments << " | "
      << fmt(s.precision) << " | " << fmt(s.recall) << " | " << fmt(s.f1) << " | " << fmt(s.iou)
      << " | " << (s.success ? "yes" : "no") << " |\n";
  }
  o << "\n**Summary** (" << m.scenes << " scenes";
  if (m.missing) o << ", " << m.missing << " without a usable labels.txt counted as failed";
  o << "): success rate " << fmt(100.0 * m.success_rate, 1) << " % (" << m.successes << "/"
    << m.scenes << "), mean point precision " << fmt(m.mean_precision) << ", recall "
    << fmt(m.mean_recall) << ", F1 " << fmt(m.mean_f1) << ", IoU " << fmt(m.mean_iou)
    << ", objects found " << m.objects_found << "/" << m.objects_total << ", false segments "
    << m.false_segments << ".\n";
  return o.str();
}

std::string suiteCsv(const std::vector<SuiteEntry>& entries) {
  std::ostringstream o;
  o << "scene,has_result,points,objects,objects_found,false_segments,fragment_segments,"
       "precision,recall,f1,iou,success,note\n";
  for (const auto& e : entries) {
    const SceneScore& s = e.score;
    o << e.name << "," << (e.has_result ? 1 : 0) << "," << s.points << "," << s.objects.size()
      << "," << s.objects_found << "," << s.false_segments << "," << s.fragment_segments << ","
      << fmt(s.precision, 6) << "," << fmt(s.recall, 6) << "," << fmt(s.f1, 6) << ","
      << fmt(s.iou, 6) << "," << (s.success ? 1 : 0) << "," << e.note << "\n";
  }
  return o.str();
}

}  // namespace novelty_detection
