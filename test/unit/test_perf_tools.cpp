// Smoke checks of the measurement tools (table1, scaling) on their smallest inputs: the CSV
// rows they promise, with accuracy values known for the first simulated suite scene. No
// timing assertions (speed is measured, not tested).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

fs::path tempDir() {
  const fs::path d =
      fs::temp_directory_path() / ("perf_tools_" + std::to_string(::getpid()) + "_" +
                                   ::testing::UnitTest::GetInstance()->current_test_info()->name());
  fs::create_directories(d);
  return d;
}

int run(const std::string& tool, const std::string& args, const fs::path& dir) {
  const std::string cmd = std::string(NOVELTY_BIN_DIR) + "/" + tool + " " + args + " > " +
                          (dir / "stdout.txt").string() + " 2> " + (dir / "stderr.txt").string();
  const int code = std::system(cmd.c_str());
  return WIFEXITED(code) ? WEXITSTATUS(code) : -1;
}

/// CSV rows as fields (no quoted commas in the tools' output except the dataset name, which
/// is quoted but has none).
std::vector<std::vector<std::string>> readCsv(const fs::path& path) {
  std::ifstream in(path);
  std::vector<std::vector<std::string>> rows;
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string t; std::getline(ss, t, ',');) f.push_back(t);
    rows.push_back(f);
  }
  return rows;
}

std::size_t column(const std::vector<std::string>& header, const std::string& name) {
  for (std::size_t i = 0; i < header.size(); ++i)
    if (header[i] == name) return i;
  ADD_FAILURE() << "no column " << name;
  return 0;
}

}  // namespace

TEST(Table1Tool, FirstSuiteSceneIsFoundWithAndWithoutSimplification) {
  const fs::path d = tempDir();
  ASSERT_EQ(
      run("table1",
          "--scenes 1 --csv " + (d / "t.csv").string() + " --real missing_a.pcd missing_b.pcd 2",
          d),
      0);
  const auto rows = readCsv(d / "t.csv");
  ASSERT_EQ(rows.size(), 3u);  // header + simplified + finest cut; the missing pair skipped
  const auto& h = rows[0];
  for (std::size_t r = 1; r < rows.size(); ++r) {
    ASSERT_EQ(rows[r].size(), h.size());
    EXPECT_EQ(rows[r][column(h, "points")], "30268");  // 28 x 1081 beams
    EXPECT_EQ(rows[r][column(h, "success_rate")], "1");
    EXPECT_GT(std::stod(rows[r][column(h, "mean_f1")]), 0.95);
    EXPECT_GT(std::stod(rows[r][column(h, "end_to_end_ms")]), 0.0);
    // The fitted superquadrics lie within a few centimetres of the segment's points.
    const double sq = std::stod(rows[r][column(h, "sq_radial_error_mm")]);
    EXPECT_GT(sq, 0.0);
    EXPECT_LT(sq, 50.0);
  }
  EXPECT_EQ(rows[1][column(h, "mode")], "simplified");
  EXPECT_EQ(rows[2][column(h, "mode")], "finest cut");
  fs::remove_all(d);
}

TEST(ScalingTool, OneSweepAndOneMapInChildProcesses) {
  const fs::path d = tempDir();
  ASSERT_EQ(run("scaling",
                "--sizes 3000 --map-sizes 10000 --repeat 1 --csv " + (d / "s.csv").string(), d),
            0);
  const auto rows = readCsv(d / "s.csv");
  ASSERT_EQ(rows.size(), 3u);
  const auto& h = rows[0];
  EXPECT_EQ(rows[1][column(h, "kind")], "detect");
  EXPECT_EQ(rows[2][column(h, "kind")], "reference");
  // Beams scale with the request: within 20 % of it.
  EXPECT_NEAR(std::stod(rows[1][column(h, "points")]), 3000.0, 600.0);
  EXPECT_NEAR(std::stod(rows[2][column(h, "points")]), 10000.0, 2000.0);
  EXPECT_GT(std::stod(rows[1][column(h, "peak_rss_mb")]), 1.0);
  EXPECT_GT(std::stod(rows[2][column(h, "peak_rss_total_mb")]), 1.0);
  fs::remove_all(d);
}

TEST(MeasurementTools, RejectUnknownArguments) {
  const fs::path d = tempDir();
  EXPECT_EQ(run("table1", "--bogus", d), 2);
  EXPECT_EQ(run("scaling", "--sizes", d), 2);
  fs::remove_all(d);
}
