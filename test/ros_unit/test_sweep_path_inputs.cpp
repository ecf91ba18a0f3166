// The sweep path's kept fuzz inputs (test/fuzz/corpus/sweep_path) with their known answers,
// and every kept input of any target through the path: a result with one label per point or
// a refusal, never a crash or another exception.
#include <gtest/gtest.h>

#include <dirent.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <vector>

#include "../fuzz/sweep_path.h"

using namespace novelty_detection;
using fuzz::SweepOutcome;

namespace {

std::string corpusDir(const std::string& target) {
  // NOVELTY_TEST_DATA_DIR is <package>/test/data (which need not exist): its parent is test/.
  const std::string data_dir = NOVELTY_TEST_DATA_DIR;
  return data_dir.substr(0, data_dir.rfind('/')) + "/fuzz/corpus/" + target;
}

std::map<std::string, std::vector<std::uint8_t>> readCorpus(const std::string& target) {
  std::map<std::string, std::vector<std::uint8_t>> files;
  const std::string dir = corpusDir(target);
  DIR* d = opendir(dir.c_str());
  if (d == nullptr) return files;
  while (dirent* e = readdir(d)) {
    if (e->d_name[0] == '.') continue;
    std::ifstream in(dir + "/" + e->d_name, std::ios::binary);
    files[e->d_name].assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  closedir(d);
  return files;
}

SweepOutcome run(const std::vector<std::uint8_t>& bytes) {
  return fuzz::runSweepPath(bytes.data(), bytes.size());
}

std::size_t novelPoints(const Result& r) {
  std::size_t n = 0;
  for (int l : r.labels) n += l > 0;
  return n;
}

}  // namespace

TEST(SweepPathInputs, KeptInputsGiveTheirKnownAnswers) {
  const auto corpus = readCorpus("sweep_path");
  ASSERT_GE(corpus.size(), 7u) << corpusDir("sweep_path");
  const std::size_t room_points = fuzz::room(true).size();
  const std::size_t box_points = room_points - fuzz::room(false).size();
  ASSERT_GT(box_points, 90u);

  // The room with its box: one novelty, the box's points.
  const SweepOutcome plain = run(corpus.at("room_unchanged"));
  ASSERT_EQ(plain.kind, SweepOutcome::kResult) << plain.error;
  ASSERT_EQ(plain.result.labels.size(), room_points);
  std::size_t box_found = 0;
  for (std::size_t i = room_points - box_points; i < room_points; ++i)
    box_found += plain.result.labels[i] > 0;
  EXPECT_GE(box_found, 0.9 * box_points);
  EXPECT_LE(novelPoints(plain.result), box_points + 10);

  // Points at 1e20, -9.3e19 and +-FLT_MAX, NaN and infinities: labelled 0, the rest unchanged.
  for (const char* name : {"room_far_points", "room_nan_inf"}) {
    const SweepOutcome o = run(corpus.at(name));
    ASSERT_EQ(o.kind, SweepOutcome::kResult) << name << ": " << o.error;
    ASSERT_EQ(o.result.labels.size(), room_points);
    for (std::size_t i = 0; i < room_points; ++i) {
      const PointT& p = o.sweep[i];
      if (!usablePoint(p)) EXPECT_EQ(o.result.labels[i], 0) << name << " point " << i;
    }
    EXPECT_EQ(novelPoints(o.result), novelPoints(plain.result)) << name;
  }

  // 20 points shrunk to denormals: one tiny cluster at the origin, the sweep still compared.
  const SweepOutcome tiny = run(corpus.at("room_denormals"));
  ASSERT_EQ(tiny.kind, SweepOutcome::kResult) << tiny.error;
  EXPECT_EQ(tiny.result.labels.size(), room_points);

  // Shifted 500 m or 1e30 m: not compared, never "no change".
  const SweepOutcome far = run(corpus.at("room_shift_500m"));
  EXPECT_EQ(far.kind, SweepOutcome::kNoOverlap) << far.error;
  const SweepOutcome huge = run(corpus.at("room_shift_huge"));
  EXPECT_TRUE(huge.kind == SweepOutcome::kNoOverlap || huge.kind == SweepOutcome::kNoPoint)
      << huge.error;
  EXPECT_NE(huge.kind, SweepOutcome::kResult);
}

TEST(SweepPathInputs, EveryKeptFuzzInputEndsInAResultOrARefusal) {
  int files = 0;
  for (const char* target : {"sweep_path", "pointcloud2"}) {
    for (const auto& [name, bytes] : readCorpus(target)) {
      ++files;
      // The pointcloud2 inputs are decoded as PointCloud2 messages (first byte even).
      std::vector<std::uint8_t> input = bytes;
      if (std::string(target) == "pointcloud2") input.insert(input.begin(), 0);
      SweepOutcome o;
      ASSERT_NO_THROW(o = run(input)) << target << "/" << name;
      if (o.kind == SweepOutcome::kResult)
        EXPECT_EQ(o.result.labels.size(), o.sweep.size()) << name;
    }
  }
  EXPECT_GE(files, 10);
}
