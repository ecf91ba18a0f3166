// scaling: end-to-end detection time and peak memory against sweep size, and reference-model
// build time against map size, each size measured in a fresh child process (this program
// re-executed with --child) so that sizes do not pollute each other's peak RSS.
//
//   scaling [--sizes 3000,30000,...] [--map-sizes 100000,...] [--repeat R]
//           [--markdown FILE] [--csv FILE]
//
// A sweep of about N points is the first scene of the simulated suite with the tilt lines
// and the beam step scaled by sqrt(N / 30268) each (the default laser: 28 x 1081 beams); the
// reference of a detection run has the same density. A map of about M points is the
// reference sweep of that scene at M beams. Peak RSS: VmHWM of the child at exit (all of
// it: simulation, both clouds, reference model and detection) and the peak during detect()
// alone (VmHWM reset through /proc/self/clear_refs before detect; it still counts what was
// resident when detect started).
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "novelty_detection/eval/evaluation.h"
#include "novelty_detection/pipeline.h"
#include "novelty_detection/sim/scene.h"

using namespace novelty_detection;

namespace {

const char* kUsage =
    "usage: scaling [--sizes N,N,...] [--map-sizes N,N,...] [--repeat R]\n"
    "               [--markdown FILE] [--csv FILE]\n";

double cpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

double nowMs() {
  return std::chrono::duration<double, std::milli>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

/// VmHWM (peak resident set) of this process in MB; 0 when /proc is not available.
double peakRssMb() {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  return 0.0;
}

void resetPeakRss() { std::ofstream("/proc/self/clear_refs") << "5"; }

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

sim::SceneConfig sceneOfSize(long points) {
  sim::SceneConfig c = sim::suiteSceneConfig(0, 1);
  const double f = std::sqrt(static_cast<double>(points) / 30268.0);
  c.laser.lines = std::max(2, static_cast<int>(std::lround(c.laser.lines * f)));
  const int beams = std::max(3, static_cast<int>(std::lround(c.laser.beamsPerLine() * f)));
  c.laser.step_deg = c.laser.fov_deg / (beams - 1);
  return c;
}

/// Child: one detection size. Prints "points wall_ms cpu_ms rss_detect_mb rss_total_mb f1
/// success".
int childDetect(long size, int repeat) {
  const sim::ScenePair s = sim::generateScenePair(sceneOfSize(size));
  Params p;
  p.preprocess.max_points = std::max<int>(p.preprocess.max_points, s.current.size());
  Pipeline pipeline(p);
  pipeline.setReference(s.reference);
  resetPeakRss();
  std::vector<double> wall, cpu;
  Result r;
  for (int i = 0; i < repeat; ++i) {
    const double c0 = cpuMs(), w0 = nowMs();
    r = pipeline.detect(s.current);
    wall.push_back(nowMs() - w0);
    cpu.push_back(cpuMs() - c0);
  }
  const double rss_detect = peakRssMb();
  const SceneScore sc = scoreLabels(r.labels, s.current_labels);
  std::printf("%zu %.3f %.3f %.1f %.1f %.4f %d\n", s.current.size(), median(wall), median(cpu),
              rss_detect, peakRssMb(), sc.f1, sc.success ? 1 : 0);
  return 0;
}

/// Child: one map size. Prints "points wall_ms cpu_ms rss_mb".
int childReference(long size, int repeat) {
  const sim::ScenePair s = sim::generateScenePair(sceneOfSize(size));
  Params p;  // defaults, with the size cap raised to the map (it guards sweeps, not maps)
  p.preprocess.max_points = std::max<int>(p.preprocess.max_points, s.reference.size());
  std::vector<double> wall, cpu;
  resetPeakRss();
  for (int i = 0; i < repeat; ++i) {
    Pipeline pipeline(p);
    const double c0 = cpuMs(), w0 = nowMs();
    pipeline.setReference(s.reference);
    wall.push_back(nowMs() - w0);
    cpu.push_back(cpuMs() - c0);
  }
  std::printf("%zu %.3f %.3f %.1f\n", s.reference.size(), median(wall), median(cpu), peakRssMb());
  return 0;
}

std::vector<double> runChild(const std::string& args) {
  std::array<char, 4096> exe{};
  const ssize_t n = readlink("/proc/self/exe", exe.data(), exe.size() - 1);
  if (n <= 0) throw std::runtime_error("cannot resolve /proc/self/exe");
  const std::string cmd = std::string(exe.data(), n) + " --child " + args;
  FILE* pipe = popen(cmd.c_str(), "r");
  if (!pipe) throw std::runtime_error("cannot run " + cmd);
  std::string out;
  std::array<char, 512> buf{};
  while (fgets(buf.data(), buf.size(), pipe)) out += buf.data();
  if (pclose(pipe) != 0) throw std::runtime_error("child failed: " + cmd);
  std::istringstream in(out);
  std::vector<double> v;
  for (double x; in >> x;) v.push_back(x);
  return v;
}

std::vector<long> parseList(const std::string& s) {
  std::vector<long> v;
  std::stringstream in(s);
  for (std::string t; std::getline(in, t, ',');) v.push_back(std::stol(t));
  return v;
}

/// Least-squares slope of log(y) over log(x): cost ~ points^slope.
double logLogSlope(const std::vector<double>& x, const std::vector<double>& y) {
  const std::size_t n = x.size();
  if (n < 2) return 0.0;
  double mx = 0, my = 0;
  for (std::size_t i = 0; i < n; ++i) {
    mx += std::log(x[i]) / n;
    my += std::log(y[i]) / n;
  }
  double sxy = 0, sxx = 0;
  for (std::size_t i = 0; i < n; ++i) {
    sxy += (std::log(x[i]) - mx) * (std::log(y[i]) - my);
    sxx += (std::log(x[i]) - mx) * (std::log(x[i]) - mx);
  }
  return sxx > 0 ? sxy / sxx : 0.0;
}

}  // namespace

int main(int argc, char** argv) try {
  if (argc >= 5 && std::string(argv[1]) == "--child") {
    const std::string kind = argv[2];
    const long size = std::stol(argv[3]);
    const int repeat = std::stoi(argv[4]);
    if (kind == "detect") return childDetect(size, repeat);
    if (kind == "reference") return childReference(size, repeat);
    throw std::invalid_argument("unknown child kind " + kind);
  }
  std::vector<long> sizes = {3000, 30000, 100000, 300000, 1000000};
  std::vector<long> map_sizes = {100000, 300000, 1000000, 2000000, 5000000};
  int repeat = 3;
  std::string markdown, csv;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
      return argv[++i];
    };
    if (a == "--sizes") {
      sizes = parseList(next());
    } else if (a == "--map-sizes") {
      map_sizes = parseList(next());
    } else if (a == "--repeat") {
      repeat = std::stoi(next());
    } else if (a == "--markdown") {
      markdown = next();
    } else if (a == "--csv") {
      csv = next();
    } else if (a == "-h" || a == "--help") {
      std::cout << kUsage;
      return 0;
    } else {
      throw std::invalid_argument("unknown argument " + a);
    }
  }
  if (repeat < 1) throw std::invalid_argument("--repeat must be >= 1");

  std::ostringstream md, cs;
  cs << "kind,requested,points,wall_ms,cpu_ms,peak_rss_mb,peak_rss_total_mb,f1,success\n";
  md << "Detection (median of " << repeat << " runs per size, each size in a fresh process):\n\n"
     << "| requested | points | end to end [ms] | CPU [ms] | peak RSS in detect [MB] |"
        " peak RSS of process [MB] | point F1 | success |\n"
        "|---:|---:|---:|---:|---:|---:|---:|---|\n";
  std::vector<double> dx, dy, rx, ry;
  for (long n : sizes) {
    const auto v = runChild("detect " + std::to_string(n) + " " + std::to_string(repeat));
    if (v.size() != 7) throw std::runtime_error("unexpected child output");
    std::fprintf(stderr, "detect %ld: %.0f points %.1f ms\n", n, v[0], v[1]);
    dx.push_back(v[0]);
    dy.push_back(v[1]);
    char line[256];
    std::snprintf(line, sizeof line, "| %ld | %.0f | %.1f | %.1f | %.0f | %.0f | %.3f | %s |\n", n,
                  v[0], v[1], v[2], v[3], v[4], v[5], v[6] ? "yes" : "no");
    md << line;
    cs << "detect," << n << "," << v[0] << "," << v[1] << "," << v[2] << "," << v[3] << "," << v[4]
       << "," << v[5] << "," << v[6] << "\n";
  }
  md << "\nGrowth exponent (log-log slope of end-to-end time over points): "
     << (dx.size() >= 2 ? std::to_string(logLogSlope(dx, dy)) : std::string("-")) << "\n\n";
  md << "Reference model (setReference, median of " << repeat << " builds per size):\n\n"
     << "| requested | map points | build [ms] | CPU [ms] | peak RSS of process [MB] |\n"
        "|---:|---:|---:|---:|---:|\n";
  for (long n : map_sizes) {
    const auto v = runChild("reference " + std::to_string(n) + " " + std::to_string(repeat));
    if (v.size() != 4) throw std::runtime_error("unexpected child output");
    std::fprintf(stderr, "reference %ld: %.0f points %.1f ms\n", n, v[0], v[1]);
    rx.push_back(v[0]);
    ry.push_back(v[1]);
    char line[256];
    std::snprintf(line, sizeof line, "| %ld | %.0f | %.1f | %.1f | %.0f |\n", n, v[0], v[1], v[2],
                  v[3]);
    md << line;
    cs << "reference," << n << "," << v[0] << "," << v[1] << "," << v[2] << ",," << v[3] << ",,\n";
  }
  md << "\nGrowth exponent of the reference build: "
     << (rx.size() >= 2 ? std::to_string(logLogSlope(rx, ry)) : std::string("-")) << "\n";
  std::cout << md.str();
  if (!markdown.empty()) std::ofstream(markdown) << md.str();
  if (!csv.empty()) std::ofstream(csv) << cs.str();
  return 0;
} catch (const std::exception& e) {
  std::cerr << "scaling: " << e.what() << "\n" << kUsage;
  return 2;
}
