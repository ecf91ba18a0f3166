// The reference model cache: a model read back gives the same detection as one built; the
// key follows the map and the settings; a damaged, truncated, oversized or foreign file is
// refused by name and replaced; a summary that does not fit its cloud is refused.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>

#include "novelty_detection/io/reference_cache.h"
#include "novelty_detection/pipeline.h"
#include "novelty_detection/sim/scene.h"
#include "temp_dir.h"

namespace fs = std::filesystem;
using namespace novelty_detection;

namespace {

fs::path tempDir(const std::string& name) { return test_helpers::freshTempDir("refcache", name); }

sim::ScenePair scene(unsigned seed) {
  sim::SceneConfig c;
  c.seed = seed;
  c.novelty_kinds = {sim::NoveltyKind::kBox, sim::NoveltyKind::kCylinder};
  return sim::generateScenePair(c);
}

std::string readAll(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

void writeAll(const fs::path& p, const std::string& bytes) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out << bytes;
}

}  // namespace

TEST(ReferenceCache, ReadBackGivesTheSameDetection) {
  const fs::path dir = tempDir("same");
  const sim::ScenePair s = scene(5);
  Pipeline built(Params{});
  const ReferenceCacheUse first = setReferenceCached(built, s.reference, {}, dir.string());
  EXPECT_EQ(first.state, "written");
  EXPECT_TRUE(first.message.empty()) << first.message;
  ASSERT_EQ(first.key.size(), 16u);
  EXPECT_TRUE(fs::exists(referenceCachePath(dir.string(), first.key)));

  Pipeline cached(Params{});
  const ReferenceCacheUse second = setReferenceCached(cached, s.reference, {}, dir.string());
  EXPECT_EQ(second.state, "hit");
  EXPECT_EQ(second.key, first.key);
  const ReferenceModelSummary a = built.referenceSummary(), b = cached.referenceSummary();
  EXPECT_EQ(a.kept, b.kept);
  ASSERT_EQ(a.gmm.size(), b.gmm.size());
  for (std::size_t k = 0; k < a.gmm.size(); ++k) {
    EXPECT_EQ(a.gmm.components[k].weight, b.gmm.components[k].weight);
    EXPECT_EQ(a.gmm.components[k].mean, b.gmm.components[k].mean);
    EXPECT_EQ(a.gmm.components[k].cov, b.gmm.components[k].cov);
  }
  EXPECT_EQ(a.explained_log_density, b.explained_log_density);
  const Result ra = built.detect(s.current), rb = cached.detect(s.current);
  EXPECT_EQ(ra.labels, rb.labels);
  ASSERT_EQ(ra.superquadrics.size(), rb.superquadrics.size());
  for (std::size_t k = 0; k < ra.superquadrics.size(); ++k)
    EXPECT_EQ(ra.superquadrics[k].a, rb.superquadrics[k].a);
  EXPECT_GE(ra.segments.size(), 1u);
  fs::remove_all(dir);
}

TEST(ReferenceCache, KeyFollowsTheMapAndTheSettings) {
  const sim::ScenePair s = scene(6);
  Params p;
  const std::string key = referenceCacheKey(p, s.reference, {});
  EXPECT_EQ(referenceCacheKey(p, s.reference, {}), key);  // deterministic
  Params threads = p;
  threads.compute.threads = 1;  // results do not depend on it
  EXPECT_EQ(referenceCacheKey(threads, s.reference, {}), key);
  Params other = p;
  other.gmm.points_per_component = 200.0;
  EXPECT_NE(referenceCacheKey(other, s.reference, {}), key);
  Cloud moved = s.reference;
  moved[moved.size() / 2].x += 1e-3f;  // one point, one millimetre
  EXPECT_NE(referenceCacheKey(p, moved, {}), key);
  Cloud elsewhere = s.reference;
  elsewhere.sensor_origin_.x() += 0.5f;  // the same points seen from another place
  EXPECT_NE(referenceCacheKey(p, elsewhere, {}), key);
  ReferenceViews views;
  views.origins = {Eigen::Vector3f(1, 2, 1)};
  views.sweep.assign(s.reference.size(), 0);
  EXPECT_NE(referenceCacheKey(p, s.reference, views), key);
}

TEST(ReferenceCache, BadFilesAreRefusedByNameAndReplaced) {
  const fs::path dir = tempDir("bad");
  const sim::ScenePair s = scene(7);
  Pipeline pipeline(Params{});
  const ReferenceCacheUse first = setReferenceCached(pipeline, s.reference, {}, dir.string());
  ASSERT_EQ(first.state, "written");
  const fs::path file = referenceCachePath(dir.string(), first.key);
  const std::string good = readAll(file);
  ASSERT_GT(good.size(), 100u);
  const Result expected = pipeline.detect(s.current);

  std::string flipped = good;
  flipped[good.size() / 2] ^= 0x10;
  std::string foreign = good;
  foreign[0] = 'X';
  std::string huge = good;  // a count far beyond the file: refused before any allocation
  const std::uint64_t big = std::uint64_t(1) << 40;
  std::memcpy(&huge[32], &big, sizeof big);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {good.substr(0, good.size() - 9), "size does not match"},
      {good.substr(0, 20), "truncated"},
      {flipped, "checksum"},
      {foreign, "not a reference model"},
      {huge, "size does not match"},
      {good + "extra", "size does not match"}};
  for (const auto& [bytes, why] : cases) {
    writeAll(file, bytes);
    EXPECT_THROW(loadReferenceSummary(dir.string(), first.key), std::runtime_error) << why;
    try {
      loadReferenceSummary(dir.string(), first.key);
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
    }
    Pipeline again(Params{});
    const ReferenceCacheUse use = setReferenceCached(again, s.reference, {}, dir.string());
    EXPECT_EQ(use.state, "replaced") << why;
    EXPECT_NE(use.message.find(why), std::string::npos) << use.message;
    EXPECT_EQ(readAll(file), good) << why;  // rewritten whole
    EXPECT_EQ(again.detect(s.current).labels, expected.labels) << why;
  }
  // A file stored under another key is another model: refused.
  const fs::path other = referenceCachePath(dir.string(), "0123456789abcdef");
  fs::copy_file(file, other);
  EXPECT_THROW(loadReferenceSummary(dir.string(), "0123456789abcdef"), std::runtime_error);
  // No file: nothing stored, not an error.
  EXPECT_FALSE(loadReferenceSummary(dir.string(), "fedcba9876543210").has_value());
  // A cache path that cannot be a directory: the model is built, the run goes on.
  const fs::path blocked = dir / "plain_file";
  writeAll(blocked, "x");
  Pipeline unwritable(Params{});
  const ReferenceCacheUse use = setReferenceCached(unwritable, s.reference, {}, blocked.string());
  EXPECT_EQ(use.state, "not written");
  EXPECT_FALSE(use.message.empty());
  EXPECT_EQ(unwritable.detect(s.current).labels, expected.labels);
  fs::remove_all(dir);
}

TEST(ReferenceCache, SummaryThatDoesNotFitTheCloudIsRefused) {
  const sim::ScenePair s = scene(8);
  Pipeline pipeline(Params{});
  pipeline.setReference(s.reference);
  const ReferenceModelSummary good = pipeline.referenceSummary();
  ASSERT_GT(good.kept.size(), 100u);
  auto refused = [&](ReferenceModelSummary bad, const Cloud& cloud) {
    Pipeline p(Params{});
    EXPECT_THROW(p.setReference(cloud, {}, bad), std::invalid_argument);
  };
  ReferenceModelSummary out_of_range = good;
  out_of_range.kept.back() = static_cast<int>(s.reference.size());
  refused(out_of_range, s.reference);
  ReferenceModelSummary unordered = good;
  std::swap(unordered.kept[0], unordered.kept[1]);
  refused(unordered, s.reference);
  Cloud holed = s.reference;
  holed[good.kept[10]].x = std::numeric_limits<float>::quiet_NaN();
  refused(good, holed);
  ReferenceModelSummary flat = good;
  flat.gmm.components[0].cov.setZero();
  refused(flat, s.reference);
  ReferenceModelSummary weightless = good;
  weightless.gmm.components[0].weight = -1.0;
  refused(weightless, s.reference);
  Pipeline fine(Params{});
  fine.setReference(s.reference, {}, good);
  EXPECT_EQ(fine.detect(s.current).labels, pipeline.detect(s.current).labels);
}
