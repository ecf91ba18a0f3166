// End to end through a real manager: a simulated scene with an inserted object yields a
// novelty whose points match the ground truth; the unchanged scene yields none.
#include <gtest/gtest.h>
#include <ros/ros.h>

#include <unistd.h>
#include <cstdio>
#include <cstring>
#include <mutex>

#include "novelty_detection/NoveltyArray.h"
#include "novelty_detection/SetReference.h"
#include "novelty_detection/cloud_io.h"
#include "novelty_detection/ros/conversions.h"
#include "novelty_detection/sim/scene.h"
#include "test_helpers.h"

using namespace novelty_detection;
using test_helpers::waitFor;

class NoveltyScenes : public ::testing::Test {
 protected:
  void SetUp() override {
    pub_ = nh_.advertise<sensor_msgs::PointCloud2>("/sweep", 2);
    sub_ = nh_.subscribe<NoveltyArray>("/detector/novelties", 5,
                                       [this](const NoveltyArray::ConstPtr& m) {
                                         std::lock_guard<std::mutex> lock(mutex_);
                                         novelties_ = m;
                                       });
    labelled_sub_ = nh_.subscribe<sensor_msgs::PointCloud2>(
        "/detector/labelled_cloud", 5, [this](const sensor_msgs::PointCloud2::ConstPtr& m) {
          std::lock_guard<std::mutex> lock(mutex_);
          labelled_ = m;
        });
    ASSERT_TRUE(waitFor(
        [this] {
          return pub_.getNumSubscribers() > 0 && sub_.getNumPublishers() > 0 &&
                 labelled_sub_.getNumPublishers() > 0;
        },
        30.0));
    ASSERT_TRUE(ros::service::waitForService("/detector/set_reference", 30000));
  }

  // Sets the scene's reference, publishes its current sweep, waits for the result; returns
  // the labels of the labelled cloud (input order).
  std::vector<std::uint32_t> run(const sim::ScenePair& scene) {
    const std::string path = "/tmp/novelty_scene_" + std::to_string(getpid()) + ".pcd";
    saveCloudAtomic(path, scene.reference, scene.T_world_sensor_reference);  // with viewpoint
    SetReference set;
    set.request.path = path;
    EXPECT_TRUE(ros::service::call("/detector/set_reference", set));
    EXPECT_TRUE(set.response.success) << set.response.message;
    std::remove(path.c_str());
    std_msgs::Header h;
    h.frame_id = "map";
    h.stamp = ros::Time::now();
    pub_.publish(toPointCloud2(scene.current, h));
    EXPECT_TRUE(waitFor(
        [&] {
          std::lock_guard<std::mutex> lock(mutex_);
          return novelties_ && labelled_ && novelties_->header.stamp == h.stamp &&
                 labelled_->header.stamp == h.stamp;
        },
        60.0))
        << "no result for the sweep";
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<std::uint32_t> labels;
    if (!labelled_) return labels;
    const auto& m = *labelled_;
    for (std::size_t i = 0; i < m.width * m.height; ++i) {
      std::uint32_t l;
      std::memcpy(&l, m.data.data() + i * m.point_step + 12, 4);
      labels.push_back(l);
    }
    return labels;
  }

  ros::NodeHandle nh_;
  ros::Publisher pub_;
  ros::Subscriber sub_, labelled_sub_;
  std::mutex mutex_;
  NoveltyArray::ConstPtr novelties_;
  sensor_msgs::PointCloud2::ConstPtr labelled_;
};

TEST_F(NoveltyScenes, InsertedBoxIsFoundWithItsPoints) {
  sim::SceneConfig cfg;
  cfg.seed = 3;
  cfg.novelty_kinds = {sim::NoveltyKind::kBox};
  const sim::ScenePair scene = sim::generateScenePair(cfg);
  std::size_t truth = 0;
  for (int l : scene.current_labels) truth += l > 0;
  ASSERT_GT(truth, 50u);

  const auto labels = run(scene);
  ASSERT_EQ(labels.size(), scene.current.size());
  std::size_t found = 0, hit = 0;
  for (std::size_t i = 0; i < labels.size(); ++i) {
    found += labels[i] > 0;
    hit += labels[i] > 0 && scene.current_labels[i] > 0;
  }
  std::printf("box scene: %zu ground-truth novel points, %zu found, %zu of them right\n", truth,
              found, hit);
  std::lock_guard<std::mutex> lock(mutex_);
  ASSERT_TRUE(novelties_);
  ASSERT_GE(novelties_->novelties.size(), 1u);
  std::size_t msg_points = 0;
  for (const auto& n : novelties_->novelties) msg_points += n.points;
  EXPECT_EQ(msg_points, found);
  // The right points, within a tolerance: most of the box, little else.
  EXPECT_NEAR(static_cast<double>(found), static_cast<double>(truth), 0.3 * truth)
      << "found " << found << " novel points, ground truth " << truth;
  EXPECT_GE(hit, 0.7 * truth) << "recall " << double(hit) / truth;
  EXPECT_GE(hit, 0.7 * found) << "precision " << double(hit) / std::max<std::size_t>(found, 1);
}

TEST_F(NoveltyScenes, UnchangedSceneHasNoNovelty) {
  sim::SceneConfig cfg;
  cfg.seed = 3;
  cfg.novelty_count = 0;
  const sim::ScenePair scene = sim::generateScenePair(cfg);
  const auto labels = run(scene);
  ASSERT_EQ(labels.size(), scene.current.size());
  std::size_t found = 0;
  for (auto l : labels) found += l > 0;
  std::lock_guard<std::mutex> lock(mutex_);
  ASSERT_TRUE(novelties_);
  EXPECT_TRUE(novelties_->novelties.empty()) << novelties_->novelties.size() << " novelties";
  EXPECT_EQ(found, 0u);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_novelty_scenes");
  ros::NodeHandle keep_alive;
  return RUN_ALL_TESTS();
}
