// End to end through a real manager: a simulated scene with an inserted object yields a
// novelty whose points match the ground truth; the unchanged scene yields none; a removed
// object (the sweep published in its sensor frame, the pose on tf) is published on
// ~disappeared_cloud with the removed object's reference points; a reference directory of
// two sweeps (set_reference, save_reference) finds an object in one sweep's shadow.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <visualization_msgs/MarkerArray.h>

#include <unistd.h>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <set>
#include <tuple>

#include "../unit/route_scene.h"
#include "novelty_detection/NoveltyArray.h"
#include "novelty_detection/SaveReference.h"
#include "novelty_detection/SetReference.h"
#include "novelty_detection/io/cloud_io.h"
#include "novelty_detection/io/reference_sweeps.h"
#include "novelty_detection/ros/conversions.h"
#include "novelty_detection/ros/result_messages.h"
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
    disappeared_sub_ = nh_.subscribe<sensor_msgs::PointCloud2>(
        "/detector/disappeared_cloud", 5, [this](const sensor_msgs::PointCloud2::ConstPtr& m) {
          std::lock_guard<std::mutex> lock(mutex_);
          disappeared_ = m;
        });
    labelled_sub_ = nh_.subscribe<sensor_msgs::PointCloud2>(
        "/detector/labelled_cloud", 5, [this](const sensor_msgs::PointCloud2::ConstPtr& m) {
          std::lock_guard<std::mutex> lock(mutex_);
          labelled_ = m;
        });
    ASSERT_TRUE(waitFor(
        [this] {
          return pub_.getNumSubscribers() > 0 && sub_.getNumPublishers() > 0 &&
                 labelled_sub_.getNumPublishers() > 0 && disappeared_sub_.getNumPublishers() > 0;
        },
        30.0));
    ASSERT_TRUE(ros::service::waitForService("/detector/set_reference", 30000));
  }

  // Sets the scene's reference, publishes its current sweep, waits for the result; returns
  // the labels of the labelled cloud (input order).
  std::vector<std::uint32_t> run(const sim::ScenePair& scene) {
    return run(scene.reference, scene.T_world_sensor_reference, scene.current, nullptr);
  }

  // As above with the clouds given; with T_map_sensor the current sweep is published in a
  // sensor frame whose pose goes on tf (so the detector knows the current viewpoint).
  std::vector<std::uint32_t> run(const Cloud& reference, const Eigen::Isometry3d& T_map_ref,
                                 const Cloud& current, const Eigen::Isometry3d* T_map_sensor) {
    const std::string path = "/tmp/novelty_scene_" + std::to_string(getpid()) + ".pcd";
    saveCloudAtomic(path, reference, T_map_ref);  // with viewpoint
    setReference(path);
    std::remove(path.c_str());
    return publish(current, T_map_sensor);
  }

  std::string setReference(const std::string& path) {
    SetReference set;
    set.request.path = path;
    EXPECT_TRUE(ros::service::call("/detector/set_reference", set));
    EXPECT_TRUE(set.response.success) << set.response.message;
    return set.response.message;
  }

  // Publishes `current` (in the map frame, or with T_map_sensor in a sensor frame on tf) and
  // waits for its result; returns the labels of the labelled cloud.
  std::vector<std::uint32_t> publish(const Cloud& current, const Eigen::Isometry3d* T_map_sensor) {
    std_msgs::Header h;
    h.frame_id = "map";
    h.stamp = ros::Time::now();
    Cloud sweep = current;
    if (T_map_sensor) {
      geometry_msgs::TransformStamped t = tf2::eigenToTransform(*T_map_sensor);
      t.header.frame_id = "map";
      t.header.stamp = h.stamp;
      t.child_frame_id = h.frame_id = "sweep_sensor";
      tf_.sendTransform(t);
      const Eigen::Isometry3f T_sensor_map = T_map_sensor->inverse().cast<float>();
      for (auto& p : sweep) p.getVector3fMap() = T_sensor_map * p.getVector3fMap();
    }
    pub_.publish(toPointCloud2(sweep, h));
    EXPECT_TRUE(waitFor(
        [&] {
          std::lock_guard<std::mutex> lock(mutex_);
          return novelties_ && labelled_ && disappeared_ && novelties_->header.stamp == h.stamp &&
                 labelled_->header.stamp == h.stamp && disappeared_->header.stamp == h.stamp;
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
  ros::Subscriber sub_, labelled_sub_, disappeared_sub_;
  tf2_ros::StaticTransformBroadcaster tf_;
  std::mutex mutex_;
  NoveltyArray::ConstPtr novelties_;
  sensor_msgs::PointCloud2::ConstPtr labelled_, disappeared_;
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
  // A sweep in the map frame without ~sensor_frame: its pose is unknown, and the message
  // says disappearances were not looked for (rather than "none").
  EXPECT_TRUE(novelties_->visibility_checked);
  EXPECT_FALSE(novelties_->disappearances_checked);
  std::size_t msg_points = 0;
  for (const auto& n : novelties_->novelties) msg_points += n.points;
  EXPECT_EQ(msg_points, found);
  // The right points, within a tolerance: most of the box, little else.
  EXPECT_NEAR(static_cast<double>(found), static_cast<double>(truth), 0.3 * truth)
      << "found " << found << " novel points, ground truth " << truth;
  EXPECT_GE(hit, 0.7 * truth) << "recall " << double(hit) / truth;
  EXPECT_GE(hit, 0.7 * found) << "precision " << double(hit) / std::max<std::size_t>(found, 1);
}

// What an operator sees: the reference map (latched, thinned), one text per novelty naming
// its id, state, size and points in its colour, the novel points in that colour, and no
// Gaussians unless asked for.
TEST_F(NoveltyScenes, OperatorDisplayFollowsTheResult) {
  visualization_msgs::MarkerArray::ConstPtr texts;
  sensor_msgs::PointCloud2::ConstPtr reference, novel;
  auto texts_sub = nh_.subscribe<visualization_msgs::MarkerArray>(
      "/detector/novelty_labels", 5, [&](const visualization_msgs::MarkerArray::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(mutex_);
        texts = m;
      });
  auto reference_sub = nh_.subscribe<sensor_msgs::PointCloud2>(
      "/detector/reference_cloud", 5, [&](const sensor_msgs::PointCloud2::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(mutex_);
        reference = m;
      });
  auto novel_sub = nh_.subscribe<sensor_msgs::PointCloud2>(
      "/detector/novelty_cloud", 5, [&](const sensor_msgs::PointCloud2::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(mutex_);
        novel = m;
      });
  ASSERT_TRUE(waitFor(
      [&] { return texts_sub.getNumPublishers() > 0 && novel_sub.getNumPublishers() > 0; }, 30.0));
  sim::SceneConfig cfg;
  cfg.seed = 3;
  cfg.novelty_kinds = {sim::NoveltyKind::kBox};
  const sim::ScenePair scene = sim::generateScenePair(cfg);
  const ros::Time before = ros::Time::now();
  run(scene);
  ASSERT_TRUE(waitFor(
      [&] {
        std::lock_guard<std::mutex> lock(mutex_);
        return texts && novel && reference && novelties_ && reference->header.stamp >= before &&
               !texts->markers.empty() &&
               texts->markers[0].header.stamp == novelties_->header.stamp &&
               novel->header.stamp == novelties_->header.stamp;
      },
      30.0));
  std::lock_guard<std::mutex> lock(mutex_);
  // The map, thinned to 5 cm voxels: fewer points than the map, none outside its box.
  const Cloud map = fromPointCloud2(*reference);
  EXPECT_EQ(reference->header.frame_id, "map");
  EXPECT_GT(map.size(), scene.reference.size() / 20);
  EXPECT_LT(map.size(), scene.reference.size());
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(1e9f), hi = -lo;
  for (const auto& p : scene.reference) {
    if (!std::isfinite(p.x)) continue;
    lo = lo.cwiseMin(p.getVector3fMap());
    hi = hi.cwiseMax(p.getVector3fMap());
  }
  for (const auto& p : map) {
    EXPECT_TRUE((p.getVector3fMap().array() >= lo.array() - 1e-3f).all() &&
                (p.getVector3fMap().array() <= hi.array() + 1e-3f).all());
  }
  // One text per novelty, above its box, "#id new: ..." (the first sighting).
  ASSERT_GE(novelties_->novelties.size(), 1u);
  ASSERT_EQ(texts->markers.size(), 1 + novelties_->novelties.size());
  for (std::size_t i = 0; i < novelties_->novelties.size(); ++i) {
    const Novelty& n = novelties_->novelties[i];
    const auto& t = texts->markers[i + 1];
    EXPECT_EQ(t.type, visualization_msgs::Marker::TEXT_VIEW_FACING);
    EXPECT_EQ(t.text.rfind("#" + std::to_string(n.id) + " new: ", 0), 0u) << t.text;
    EXPECT_NE(t.text.find(std::to_string(n.points) + " pts"), std::string::npos) << t.text;
    EXPECT_GT(t.pose.position.z, n.bbox_max.z);
    EXPECT_FLOAT_EQ(t.color.g, 0.5f * (segmentColour(n.id).g + 1.0f));
  }
  // The novel points carry their novelty's colour.
  ASSERT_EQ(novel->fields.size(), 5u);
  for (std::size_t i = 0; i < novel->width * novel->height; ++i) {
    std::uint32_t l, rgb;
    std::memcpy(&l, novel->data.data() + i * novel->point_step + 12, 4);
    std::memcpy(&rgb, novel->data.data() + i * novel->point_step + 16, 4);
    const auto c = segmentColour(static_cast<int>(l));
    ASSERT_EQ(rgb & 0xff, static_cast<std::uint32_t>(std::lround(c.b * 255)));
  }
  // Gaussians are off by default: nobody publishes them.
  ros::master::V_TopicInfo topics;
  ASSERT_TRUE(ros::master::getTopics(topics));
  for (const auto& t : topics) EXPECT_NE(t.name, "/detector/gaussians");
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

TEST_F(NoveltyScenes, RemovedBoxIsPublishedAsDisappeared) {
  // An inserted box read backwards: the reference holds it, the current sweep does not.
  sim::SceneConfig cfg;
  cfg.seed = 3;
  cfg.novelty_kinds = {sim::NoveltyKind::kBox};
  const sim::ScenePair scene = sim::generateScenePair(cfg);
  using Key = std::tuple<float, float, float>;
  std::set<Key> box;
  for (std::size_t i = 0; i < scene.current.size(); ++i) {
    const auto& p = scene.current[i];
    if (scene.current_labels[i] > 0) box.insert(Key(p.x, p.y, p.z));
  }
  ASSERT_GT(box.size(), 50u);
  const auto labels = run(scene.current, scene.T_world_sensor_current, scene.reference,
                          &scene.T_world_sensor_reference);
  ASSERT_EQ(labels.size(), scene.reference.size());
  std::size_t novel = 0;
  for (auto l : labels) novel += l > 0;
  EXPECT_EQ(novel, 0u) << "the removed box must not be novel";
  std::lock_guard<std::mutex> lock(mutex_);
  ASSERT_TRUE(disappeared_ && novelties_);
  const auto& m = *disappeared_;
  ASSERT_EQ(m.fields.size(), 5u);  // x y z label rgb
  std::size_t hit = 0;
  for (std::size_t i = 0; i < m.width * m.height; ++i) {
    float xyz[3];
    std::uint32_t l;
    std::memcpy(xyz, m.data.data() + i * m.point_step, 12);
    std::memcpy(&l, m.data.data() + i * m.point_step + 12, 4);
    EXPECT_GT(l, 0u);
    hit += box.count(Key(xyz[0], xyz[1], xyz[2]));
  }
  const std::size_t published = m.width * m.height;
  std::printf("removed box: %zu reference points, %zu published as disappeared, %zu right\n",
              box.size(), published, hit);
  EXPECT_GE(hit, 0.8 * box.size()) << "recall";
  EXPECT_GE(hit, 0.8 * published) << "precision";
  ASSERT_GE(novelties_->disappeared.size(), 1u);
  std::size_t msg_points = 0;
  for (const auto& d : novelties_->disappeared) msg_points += d.points;
  EXPECT_EQ(msg_points, published);
}

TEST_F(NoveltyScenes, ReferenceDirectoryOfTwoSweeps) {
  using namespace route_scene;
  const std::string dir = "/tmp/novelty_route_" + std::to_string(getpid());
  std::vector<CloudFile> sweeps(2);
  sweeps[0].cloud = sweepFrom(kA, {kPillar}, false, 1).cloud;
  sweeps[0].T_frame_sensor.translation() = kA;
  sweeps[1].cloud = sweepFrom(kB, {kPillar}, true, 2).cloud;
  sweeps[1].T_frame_sensor.translation() = kB;
  saveReferenceSweeps(dir, sweeps);
  const std::string message = setReference(dir);
  EXPECT_NE(message.find("2 sweeps"), std::string::npos) << message;
  const synthetic::Scene current = sweepFrom(kC, {kPillar, kObject}, true, 3);
  Eigen::Isometry3d T_map_sensor = Eigen::Isometry3d::Identity();
  T_map_sensor.translation() = kC;
  const auto labels = publish(current.cloud, &T_map_sensor);
  ASSERT_EQ(labels.size(), current.cloud.size());
  std::size_t truth = 0, found = 0, hit = 0;
  for (std::size_t i = 0; i < labels.size(); ++i) {
    const bool object = current.label[i] == synthetic::kObject + 1;
    truth += object;
    found += labels[i] > 0;
    hit += object && labels[i] > 0;
  }
  std::printf("object in sweep A's shadow: %zu points, %zu found, %zu right\n", truth, found, hit);
  EXPECT_GE(static_cast<double>(hit) / (truth + found - hit), 0.8) << "IoU";
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ASSERT_TRUE(novelties_);
    EXPECT_TRUE(novelties_->visibility_checked);
    EXPECT_TRUE(novelties_->disappearances_checked);  // the sweep's pose is on tf
  }

  // Saved under a directory name, the map keeps its two sweeps and their viewpoints.
  SaveReference save;
  save.request.path = "route_" + std::to_string(getpid());
  ASSERT_TRUE(ros::service::call("/detector/save_reference", save));
  ASSERT_TRUE(save.response.success) << save.response.message;
  const std::string saved = save.response.message.substr(save.response.message.rfind(' ') + 1);
  const ReferenceMap back = loadReference(saved);
  ASSERT_EQ(back.views.origins.size(), 2u);
  EXPECT_TRUE(back.views.origins[1].isApprox(kB.cast<float>()));
  EXPECT_EQ(back.cloud.size(), sweeps[0].cloud.size() + sweeps[1].cloud.size());
  std::filesystem::remove_all(saved);
  std::filesystem::remove_all(dir);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_novelty_scenes");
  ros::NodeHandle keep_alive;
  return RUN_ALL_TESTS();
}
