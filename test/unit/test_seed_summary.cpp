// Scores over several suite seeds (eval/seed_summary.h): known means and worst seeds from
// hand-written scores files, and clear errors for bad ones.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "novelty_detection/eval/seed_summary.h"
#include "novelty_detection/eval/viewpoint_evaluation.h"

namespace fs = std::filesystem;
using namespace novelty_detection;

namespace {

fs::path tempDir() {
  const fs::path d = fs::temp_directory_path() / ("seed_summary_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

/// A scores file of the suite mode: two groups and "all".
std::string scores(const fs::path& dir, const std::string& name, double same, double offset,
                   double f1_same, double f1_offset, int found) {
  const fs::path p = dir / name;
  std::ofstream(p) << "{\"groups\": ["
                   << "{\"group\": \"same_pose\", \"scenes\": 20, \"success_rate\": " << same
                   << ", \"mean_f1\": " << f1_same << "},"
                   << "{\"group\": \"pose_offset\", \"scenes\": 10, \"success_rate\": " << offset
                   << ", \"mean_f1\": " << f1_offset << "},"
                   << "{\"group\": \"all\", \"scenes\": 30, \"success_rate\": "
                   << (20 * same + 10 * offset) / 30 << ", \"mean_f1\": 0.9}],"
                   << "\"kinds\": [{\"type\": \"door\", \"objects\": 10, \"found\": " << found - 50
                   << "}],"
                   << "\"summary\": {\"objects_found\": " << found
                   << ", \"objects_total\": 60, \"false_segments\": 1}}";
  return p.string();
}

}  // namespace

TEST(SeedSummary, MeansOverSeedsAndTheWorstSeed) {
  const fs::path dir = tempDir();
  const SeedSummary s = summarizeSeeds({{"1", scores(dir, "a.json", 1.0, 0.9, 0.97, 0.93, 59)},
                                        {"2", scores(dir, "b.json", 0.95, 0.7, 0.95, 0.80, 55)},
                                        {"3", scores(dir, "c.json", 0.95, 0.8, 0.94, 0.85, 57)}});
  ASSERT_EQ(s.groups.size(), 3u);
  EXPECT_EQ(s.groups[0].group, "same_pose");
  EXPECT_EQ(s.groups[2].group, "all");
  const SeedGroupSummary& same = s.groups[0];
  EXPECT_EQ(same.seeds, 3);
  EXPECT_EQ(same.scenes, 60);
  EXPECT_NEAR(same.mean_success, (1.0 + 0.95 + 0.95) / 3, 1e-12);
  EXPECT_NEAR(same.mean_f1, (0.97 + 0.95 + 0.94) / 3, 1e-12);
  // Seeds 2 and 3 tie on success; the lower F1 (seed 3) is the worst.
  EXPECT_EQ(same.worst_seed, "3");
  EXPECT_DOUBLE_EQ(same.worst_f1, 0.94);
  const SeedGroupSummary& offset = s.groups[1];
  EXPECT_EQ(offset.worst_seed, "2");
  EXPECT_DOUBLE_EQ(offset.worst_success, 0.7);
  EXPECT_DOUBLE_EQ(offset.min_f1, 0.80);
  EXPECT_EQ(s.objects_found, 59 + 55 + 57);
  EXPECT_EQ(s.objects_total, 180);
  EXPECT_EQ(s.false_segments, 3);
  const std::string md = seedSummaryMarkdown(s);
  EXPECT_NE(md.find("| pose_offset | 3 | 30 | 80.0 % | 2: 70.0 %, 0.800 | 0.860 | 0.800 |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("Suite seeds 1, 2, 3: objects found 171/180"), std::string::npos) << md;
  EXPECT_NE(seedSummaryJson(s).find("\"worst_seed\": \"2\""), std::string::npos);
  // Doors: 9 + 5 + 7 of 30 found, the worst seed 2 (5 of 10).
  ASSERT_EQ(s.kinds.size(), 1u);
  EXPECT_EQ(s.kinds[0].found, 21);
  EXPECT_EQ(s.kinds[0].objects, 30);
  EXPECT_EQ(s.kinds[0].worst_seed, "2");
  EXPECT_DOUBLE_EQ(s.kinds[0].worst_rate, 0.5);
  EXPECT_NE(md.find("| door | 70.0 % (21/30) | 2: 50.0 % |"), std::string::npos) << md;
  fs::remove_all(dir);
}

// Shapes per object type are pooled over the seeds: each found object weighs the same, so
// a seed with more boxes counts more; a seed without one-part fits adds none.
TEST(SeedSummary, ShapesArePooledOverTheSeeds) {
  const fs::path dir = tempDir();
  auto file = [&](const std::string& name, int objects, double surface, double floor,
                  int axis_objects, double axis, const std::string& seen = "") {
    const fs::path p = dir / name;
    std::ofstream(p) << "{\"groups\": [{\"group\": \"all\", \"scenes\": 1, "
                        "\"success_rate\": 1, \"mean_f1\": 1}], \"summary\": "
                        "{\"objects_found\": 1, \"objects_total\": 1, \"false_segments\": 0, "
                        "\"shapes_by_kind\": [{\"type\": \"box\", \"objects\": "
                     << objects << ", \"surface_error_m\": " << surface
                     << ", \"floor_m\": " << floor << ", \"semi_axis_objects\": " << axis_objects
                     << ", \"semi_axis_error_m\": " << axis << seen << "}]}}";
    return p.string();
  };
  // The first seed's file holds the well-seen figures, the second's (written before they
  // were kept) none.
  const SeedSummary s = summarizeSeeds(
      {{"1", file("a.json", 3, 0.020, 0.010, 2, 0.030,
                  ", \"seen_semi_axis_objects\": 1, \"seen_semi_axis_error_m\": 0.012, "
                  "\"seen_objects\": 2, \"seen_parts_3_to_7\": 0")},
       {"2", file("b.json", 1, 0.040, 0.030, 0, 0.0)}});
  ASSERT_EQ(s.shapes.size(), 1u);
  EXPECT_EQ(s.shapes[0].objects, 4);
  EXPECT_NEAR(s.shapes[0].surface_m, (3 * 0.020 + 0.040) / 4, 1e-12);
  EXPECT_NEAR(s.shapes[0].floor_m, (3 * 0.010 + 0.030) / 4, 1e-12);
  EXPECT_EQ(s.shapes[0].axis_objects, 2);
  EXPECT_NEAR(s.shapes[0].semi_axis_m, 0.030, 1e-12);
  EXPECT_EQ(s.shapes[0].seen_axis_objects, 1);
  EXPECT_NEAR(s.shapes[0].seen_semi_axis_m, 0.012, 1e-12);
  EXPECT_EQ(s.shapes[0].seen_objects, 2);
  const std::string md = seedSummaryMarkdown(s);
  EXPECT_NE(md.find("| box | 4 | 25.0 mm | 15.0 mm | 1.67 | 30.0 mm (2) | 12.0 mm (1) |"),
            std::string::npos)
      << md;
  EXPECT_NE(seedSummaryJson(s).find("\"semi_axis_objects\": 2"), std::string::npos);
  fs::remove_all(dir);
}

TEST(SeedSummary, BadInputIsNamed) {
  const fs::path dir = tempDir();
  const std::string good = scores(dir, "a.json", 1.0, 0.9, 0.97, 0.93, 59);
  EXPECT_THROW(summarizeSeeds({}), std::invalid_argument);
  EXPECT_THROW(summarizeSeeds({{"1", good}, {"1", good}}), std::invalid_argument);
  auto message = [](const std::vector<std::pair<std::string, std::string>>& in) {
    try {
      summarizeSeeds(in);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message({{"1", (dir / "none.json").string()}}).find("cannot read"), std::string::npos);
  std::ofstream(dir / "bad.json") << "{\"groups\": [";
  EXPECT_NE(message({{"1", (dir / "bad.json").string()}}).find("not valid JSON"),
            std::string::npos);
  std::ofstream(dir / "nosummary.json") << "{\"groups\": []}";
  EXPECT_NE(message({{"1", (dir / "nosummary.json").string()}}).find("no 'summary'"),
            std::string::npos);
  fs::remove_all(dir);
}

// Per object type within one suite (viewpoint_evaluation.h): objects without current points
// (removed ones) do not count; a scene counts when every object of the type in it was found;
// a scene without a result finds nothing.
TEST(KindSummary, ObjectsAndScenesPerType) {
  auto object = [](int id, std::size_t points, bool found) {
    ObjectScore o;
    o.id = id, o.points = points, o.found = found;
    return o;
  };
  ViewpointSceneScore a;  // two doors, one found; a person found
  a.has_result = true;
  a.object_types = {{1, "door"}, {2, "door"}, {3, "person"}};
  a.appearance.objects = {object(1, 100, true), object(2, 80, false), object(3, 50, true)};
  ViewpointSceneScore b;  // one door found, a removed box (no current points)
  b.has_result = true;
  b.object_types = {{1, "door"}, {2, "box"}};
  b.appearance.objects = {object(1, 60, true), object(2, 0, false)};
  ViewpointSceneScore c = b;  // the same, without a result
  c.has_result = false;
  const std::vector<KindSummary> k = summarizeKinds({a, b, c});
  ASSERT_EQ(k.size(), 2u);  // box never had points
  EXPECT_EQ(k[0].type, "door");
  EXPECT_EQ(k[0].objects, 4);
  EXPECT_EQ(k[0].found, 2);
  EXPECT_EQ(k[0].scenes, 3);
  EXPECT_EQ(k[0].scenes_found, 1);
  EXPECT_EQ(k[1].type, "person");
  EXPECT_EQ(k[1].found, 1);
  EXPECT_NE(kindsMarkdown(k).find("| door | 50 % (2/4) | 33 % (1/3) |"), std::string::npos);
}
