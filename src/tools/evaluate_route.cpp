// evaluate_route: patrol-route scenes (sim/route.h) scored against their ground truth.
//
//   evaluate_route [--scenes N] [--seed SEED] [--params FILE] [--markdown FILE]
//                  [--no-comparisons]
//
// For N route scenes of a suite seed: a reference of 8-20 sweeps with their viewpoints and a
// sequence of 5 current sweeps (an object that stays, a person walking through). Each scene
// prints one progress line on stderr; the last line on stdout is one JSON object with
// success_rate, mean_f1 (per current sweep, against the route map), confirmed_rate (objects
// that stay, confirmed by the last sweep), transient_rejected_rate (persons never confirmed),
// the single-sweep reference and the voxel-difference baseline on the same sweeps, and the
// model and detection times. docs/evaluation.md defines each figure.
#include <fstream>
#include <iomanip>
#include <iostream>
#include <string>
#include <vector>

#include "novelty_detection/eval/route_evaluation.h"
#include "novelty_detection/io/params_io.h"
#include "tool_main.h"

using namespace novelty_detection;

namespace {

const char* kUsage =
    "usage: evaluate_route [--scenes N] [--seed SEED] [--params FILE] [--markdown FILE]\n"
    "                      [--no-comparisons]\n";

struct Options {
  int scenes = 30;
  std::uint64_t seed = 1;
  std::string params, markdown;
  bool comparisons = true;
};

/// A non-negative integer, all of `text`; throws naming it otherwise.
unsigned long long count(const std::string& text) {
  if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos || text.size() > 19)
    throw std::invalid_argument("'" + text + "' is not a non-negative integer");
  return std::stoull(text);
}

Options parse(int argc, char** argv) {
  Options o;
  std::vector<std::string> a(argv + 1, argv + argc);
  for (std::size_t i = 0; i < a.size(); ++i) {
    const std::string& f = a[i];
    if (f == "--help" || f == "-h") {
      std::cout << kUsage;
      std::exit(0);
    }
    if (f == "--no-comparisons") {
      o.comparisons = false;
      continue;
    }
    if (i + 1 >= a.size()) throw std::invalid_argument(f + " needs a value");
    const std::string v = a[++i];
    if (f == "--scenes") {
      const unsigned long long n = count(v);
      if (n < 1 || n > 1000) throw std::invalid_argument("--scenes takes 1-1000, got '" + v + "'");
      o.scenes = static_cast<int>(n);
    } else if (f == "--seed") {
      o.seed = count(v);
    } else if (f == "--params") {
      o.params = v;
    } else if (f == "--markdown") {
      o.markdown = v;
    } else {
      throw std::invalid_argument("unknown argument '" + f + "'");
    }
  }
  return o;
}

int run(const Options& o) {
  Params params;
  if (!o.params.empty()) loadParamsYaml(o.params, params);
  params.validate();
  std::vector<RouteSceneResult> results;
  int skipped = 0;
  for (int i = 0; i < o.scenes; ++i) {
    sim::RouteScene scene;
    try {
      scene = sim::generateRoute(sim::routeSceneConfig(i, o.seed));
    } catch (const std::runtime_error& e) {
      // The simulator found no layout for this scene: not a detection, said and counted.
      std::cerr << "[" << i + 1 << "/" << o.scenes << "] skipped: " << e.what() << std::endl;
      ++skipped;
      continue;
    }
    results.push_back(evaluateRouteScene(scene, i, params, BaselineOptions(), o.comparisons));
    const RouteSceneResult& r = results.back();
    int ok = 0;
    for (const auto& s : r.route.sweeps) ok += s.success;
    std::cerr << "[" << i + 1 << "/" << o.scenes << "] " << r.layout << ", " << r.reference_sweeps
              << " sweeps (" << r.reference_points << " points): " << ok << "/"
              << r.route.sweeps.size() << " sweeps right, object "
              << (r.object_confirmed ? "confirmed" : "NOT confirmed") << ", person "
              << (r.person_rejected ? "rejected" : "CONFIRMED") << ", model " << std::fixed
              << std::setprecision(2) << r.route.reference_ms / 1000.0 << " s" << std::endl;
  }
  const RouteSummary summary = summarizeRoutes(results);
  if (!o.markdown.empty()) {
    std::ofstream md(o.markdown);
    md << routeMarkdown(results, summary);
    if (!md.flush()) throw std::runtime_error(o.markdown + ": cannot write");
  }
  std::cout << routeSummaryJson(summary, skipped) << std::endl;
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return runTool("evaluate_route", std::string("\n") + kUsage, argc, argv, parse, run);
}
