// The scorer on small hand-made label sets with known answers.
#include <gtest/gtest.h>

#include <fstream>

#include "novelty_detection/eval/evaluation.h"

using namespace novelty_detection;

namespace {
std::string tmpPath(const std::string& name) {
  return ::testing::TempDir() + "/novelty_eval_" + name;
}
void writeText(const std::string& path, const std::string& text) { std::ofstream(path) << text; }
std::string errorOf(const std::string& path, long expected = -1) {
  try {
    readLabelFile(path, expected);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}
// Labels with `value` on [begin, end).
void fill(std::vector<int>& v, int begin, int end, int value) {
  for (int i = begin; i < end; ++i) v[i] = value;
}
}  // namespace

TEST(Evaluation, PointAndObjectScoresOnAHandMadeScene) {
  const std::vector<int> truth = {0, 0, 0, 0, 1, 1, 1, 1, 2, 2};
  const std::vector<int> pred = {0, 0, 0, 3, 3, 3, 3, 0, 5, 5};
  const SceneScore s = scoreLabels(pred, truth);
  EXPECT_EQ(s.tp, 5u);
  EXPECT_EQ(s.fp, 1u);
  EXPECT_EQ(s.fn, 1u);
  EXPECT_EQ(s.tn, 3u);
  EXPECT_DOUBLE_EQ(s.precision, 5.0 / 6.0);
  EXPECT_DOUBLE_EQ(s.recall, 5.0 / 6.0);
  EXPECT_DOUBLE_EQ(s.f1, 5.0 / 6.0);
  EXPECT_DOUBLE_EQ(s.iou, 5.0 / 7.0);
  ASSERT_EQ(s.objects.size(), 2u);
  EXPECT_EQ(s.objects[0].best_segment, 3);
  EXPECT_DOUBLE_EQ(s.objects[0].best_iou, 3.0 / 5.0);  // {3,4,5,6} vs {4,5,6,7}
  EXPECT_TRUE(s.objects[0].found);
  EXPECT_DOUBLE_EQ(s.objects[1].best_iou, 1.0);
  EXPECT_EQ(s.objects_found, 2);
  EXPECT_EQ(s.false_segments, 0);
  EXPECT_TRUE(s.success);
}

TEST(Evaluation, FalseSegmentFailsTheSceneOnlyAboveOnePercent) {
  std::vector<int> truth(200, 0), pred(200, 0);
  fill(truth, 0, 10, 1);
  fill(pred, 0, 10, 1);
  fill(pred, 100, 102, 2);  // 2 points = 1 % of the scan: tolerated
  SceneScore s = scoreLabels(pred, truth);
  EXPECT_EQ(s.false_segments, 1);
  EXPECT_EQ(s.largest_false_segment, 2u);
  EXPECT_TRUE(s.success);
  EXPECT_DOUBLE_EQ(s.precision, 10.0 / 12.0);
  fill(pred, 100, 103, 2);  // 3 points = 1.5 %
  s = scoreLabels(pred, truth);
  EXPECT_FALSE(s.success);
  EXPECT_EQ(s.objects_found, 1);
}

TEST(Evaluation, FragmentsAreNotFalseSegmentsAndWeakOverlapIsAMiss) {
  std::vector<int> truth(50, 0), pred(50, 0);
  fill(truth, 0, 10, 1);
  fill(pred, 0, 4, 1);   // IoU 0.4: a fragment
  fill(pred, 4, 10, 2);  // IoU 0.6: the detection
  SceneScore s = scoreLabels(pred, truth);
  EXPECT_EQ(s.objects_found, 1);
  EXPECT_EQ(s.objects[0].best_segment, 2);
  EXPECT_EQ(s.fragment_segments, 1);
  EXPECT_EQ(s.false_segments, 0);
  EXPECT_TRUE(s.success);
  EXPECT_DOUBLE_EQ(s.f1, 1.0);

  fill(pred, 4, 10, 0);  // only the fragment remains: object missed
  s = scoreLabels(pred, truth);
  EXPECT_EQ(s.objects_found, 0);
  EXPECT_FALSE(s.success);
  EXPECT_DOUBLE_EQ(s.precision, 1.0);
  EXPECT_DOUBLE_EQ(s.recall, 0.4);
  EXPECT_DOUBLE_EQ(s.iou, 0.4);
}

TEST(Evaluation, EdgeCasesOfEmptyMasks) {
  const std::vector<int> zeros(20, 0);
  SceneScore s = scoreLabels(zeros, zeros);  // nothing to find, nothing claimed
  EXPECT_DOUBLE_EQ(s.precision, 1.0);
  EXPECT_DOUBLE_EQ(s.recall, 1.0);
  EXPECT_DOUBLE_EQ(s.f1, 1.0);
  EXPECT_DOUBLE_EQ(s.iou, 1.0);
  EXPECT_TRUE(s.success);

  std::vector<int> truth = zeros;
  fill(truth, 0, 5, 1);
  s = scoreLabels(zeros, truth);  // silence while something changed
  EXPECT_DOUBLE_EQ(s.precision, 0.0);
  EXPECT_DOUBLE_EQ(s.recall, 0.0);
  EXPECT_DOUBLE_EQ(s.f1, 0.0);
  EXPECT_FALSE(s.success);

  s = scoreLabels(truth, zeros);  // an alarm while nothing changed (25 % of the scan)
  EXPECT_DOUBLE_EQ(s.precision, 0.0);
  EXPECT_DOUBLE_EQ(s.iou, 0.0);
  EXPECT_EQ(s.false_segments, 1);
  EXPECT_FALSE(s.success);

  EXPECT_THROW(scoreLabels(std::vector<int>(3, 0), zeros), std::invalid_argument);
  EXPECT_THROW(scoreLabels(std::vector<int>{0, -1}, std::vector<int>{0, 0}), std::invalid_argument);
  EvaluationOptions bad;
  bad.match_iou = 0.0;
  EXPECT_THROW(scoreLabels(zeros, zeros, bad), std::invalid_argument);
}

TEST(Evaluation, LabelFilesAreReadStrictly) {
  const std::string ok = tmpPath("ok.txt");
  writeText(ok, "0\n1\n  2 \n\n3");
  EXPECT_EQ(readLabelFile(ok), (std::vector<int>{0, 1, 2, 3}));
  EXPECT_NE(errorOf(ok, 5).find("4 labels, expected 5"), std::string::npos);
  const std::string bad = tmpPath("bad.txt");
  writeText(bad, "0\n1.5\n");
  EXPECT_NE(errorOf(bad).find(":2: '1.5' is not an integer"), std::string::npos);
  writeText(bad, "0\n-2\n");
  EXPECT_NE(errorOf(bad).find("negative label"), std::string::npos);
  EXPECT_NE(errorOf(tmpPath("missing.txt")).find("cannot open"), std::string::npos);
  const std::string round = tmpPath("round.txt");
  writeLabelFile(round, {4, 0, 7});
  EXPECT_EQ(readLabelFile(round, 3), (std::vector<int>{4, 0, 7}));
}

TEST(Evaluation, SuiteSummaryCountsMissingResultsAsFailures) {
  std::vector<int> truth(100, 0);
  fill(truth, 0, 10, 1);
  SuiteEntry good{"scene_000", true, "", scoreLabels(truth, truth)};
  SuiteEntry missing{"scene_001", false, "missing labels.txt",
                     scoreLabels(std::vector<int>(100, 0), truth)};
  const SuiteSummary m = summarizeSuite({good, missing});
  EXPECT_EQ(m.scenes, 2);
  EXPECT_EQ(m.successes, 1);
  EXPECT_EQ(m.missing, 1);
  EXPECT_DOUBLE_EQ(m.success_rate, 0.5);
  EXPECT_DOUBLE_EQ(m.mean_f1, 0.5);
  EXPECT_EQ(m.objects_found, 1);
  EXPECT_EQ(m.objects_total, 2);
  const std::string md = suiteMarkdown({good, missing}, m);
  EXPECT_NE(md.find("missing labels.txt"), std::string::npos);
  EXPECT_NE(md.find("success rate 50.0 %"), std::string::npos);
  const std::string csv = suiteCsv({good, missing});
  EXPECT_NE(csv.find("scene_000,1,100,1,1,0,0,1.000000"), std::string::npos);
}
