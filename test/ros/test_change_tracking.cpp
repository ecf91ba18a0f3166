// Changes over time through a real manager, on a simulated patrol route with exact ground
// truth: the object that stays keeps one track id, is confirmed on its second sweep and is
// published on ~confirmed_novelties; the walking person never is. Then ~set_ignore_regions:
// a box over the object hides it (its points are counted as ignored), a bad box is refused
// naming the parameter and the regions in force stay.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <unistd.h>
#include <cstring>
#include <filesystem>
#include <map>
#include <mutex>

#include "novelty_detection/NoveltyArray.h"
#include "novelty_detection/SetIgnoreRegions.h"
#include "novelty_detection/SetReference.h"
#include "novelty_detection/io/reference_sweeps.h"
#include "novelty_detection/preprocess/ignore_regions.h"
#include "novelty_detection/ros/conversions.h"
#include "novelty_detection/sim/route.h"
#include "test_helpers.h"

using namespace novelty_detection;
using test_helpers::waitFor;

namespace {

struct SweepResult {
  NoveltyArray all, confirmed;
  std::vector<std::uint32_t> labels;  // per point of the sweep
};

/// The ground-truth label most points of a novelty's segment carry.
int majority(const std::vector<std::uint32_t>& labels, const std::vector<int>& truth, int id) {
  std::map<int, std::size_t> votes;
  std::size_t n = 0;
  for (std::size_t i = 0; i < labels.size(); ++i)
    if (labels[i] == static_cast<std::uint32_t>(id)) ++votes[truth[i]], ++n;
  for (const auto& [label, count] : votes)
    if (2 * count > n) return label;
  return -1;
}

}  // namespace

class ChangeTracking : public ::testing::Test {
 protected:
  void SetUp() override {
    pub_ = nh_.advertise<sensor_msgs::PointCloud2>("/sweep", 2);
    all_sub_ = nh_.subscribe<NoveltyArray>("/detector/novelties", 5,
                                           [this](const NoveltyArray::ConstPtr& m) {
                                             std::lock_guard<std::mutex> lock(mutex_);
                                             all_ = m;
                                           });
    confirmed_sub_ = nh_.subscribe<NoveltyArray>("/detector/confirmed_novelties", 5,
                                                 [this](const NoveltyArray::ConstPtr& m) {
                                                   std::lock_guard<std::mutex> lock(mutex_);
                                                   confirmed_ = m;
                                                 });
    labelled_sub_ = nh_.subscribe<sensor_msgs::PointCloud2>(
        "/detector/labelled_cloud", 5, [this](const sensor_msgs::PointCloud2::ConstPtr& m) {
          std::lock_guard<std::mutex> lock(mutex_);
          labelled_ = m;
        });
    ASSERT_TRUE(waitFor(
        [this] {
          return pub_.getNumSubscribers() > 0 && all_sub_.getNumPublishers() > 0 &&
                 confirmed_sub_.getNumPublishers() > 0 && labelled_sub_.getNumPublishers() > 0;
        },
        30.0));
    ASSERT_TRUE(ros::service::waitForService("/detector/set_reference", 30000));
  }

  SweepResult publish(const sim::RouteSweep& sweep, int k) {
    std_msgs::Header h;
    h.frame_id = "route_sensor_" + std::to_string(k);  // one frame per pose: no race on tf
    h.stamp = ros::Time(1000.0 + 2.0 * k);
    geometry_msgs::TransformStamped t = tf2::eigenToTransform(sweep.T_world_sensor);
    t.header.frame_id = "map";
    t.header.stamp = h.stamp;
    t.child_frame_id = h.frame_id;
    tf_.sendTransform(t);
    Cloud local = sweep.cloud;
    const Eigen::Isometry3f T_sensor_map = sweep.T_world_sensor.inverse().cast<float>();
    for (auto& p : local) p.getVector3fMap() = T_sensor_map * p.getVector3fMap();
    pub_.publish(toPointCloud2(local, h));
    EXPECT_TRUE(waitFor(
        [&] {
          std::lock_guard<std::mutex> lock(mutex_);
          return all_ && confirmed_ && labelled_ && all_->header.stamp == h.stamp &&
                 confirmed_->header.stamp == h.stamp && labelled_->header.stamp == h.stamp;
        },
        90.0))
        << "no result for sweep " << k;
    std::lock_guard<std::mutex> lock(mutex_);
    SweepResult r;
    if (!all_ || !confirmed_ || !labelled_) return r;
    r.all = *all_;
    r.confirmed = *confirmed_;
    const auto& m = *labelled_;
    for (std::size_t i = 0; i < m.width * m.height; ++i) {
      std::uint32_t l;
      std::memcpy(&l, m.data.data() + i * m.point_step + 12, 4);
      r.labels.push_back(l);
    }
    return r;
  }

  ros::NodeHandle nh_;
  ros::Publisher pub_;
  ros::Subscriber all_sub_, confirmed_sub_, labelled_sub_;
  tf2_ros::StaticTransformBroadcaster tf_;
  std::mutex mutex_;
  NoveltyArray::ConstPtr all_, confirmed_;
  sensor_msgs::PointCloud2::ConstPtr labelled_;
};

TEST_F(ChangeTracking, AChangeThatStaysIsConfirmedAPersonWalkingByIsNot) {
  sim::RouteConfig cfg;
  cfg.seed = 3;
  cfg.reference_sweeps = 8;
  cfg.sequence_sweeps = 4;
  const sim::RouteScene scene = sim::generateRoute(cfg);
  const std::string dir = "/tmp/novelty_tracking_" + std::to_string(getpid());
  std::vector<CloudFile> sweeps;
  for (const auto& s : scene.reference) sweeps.push_back({s.cloud, s.T_world_sensor});
  saveReferenceSweeps(dir, sweeps);
  SetReference set;
  set.request.path = dir;
  ASSERT_TRUE(ros::service::call("/detector/set_reference", set));
  ASSERT_TRUE(set.response.success) << set.response.message;
  std::filesystem::remove_all(dir);

  std::uint32_t object_track = 0;
  int person_sightings = 0;
  for (int k = 0; k < cfg.sequence_sweeps; ++k) {
    const sim::RouteSweep& sweep = scene.sequence[k];
    const SweepResult r = publish(sweep, k);
    ASSERT_EQ(r.labels.size(), sweep.cloud.size());
    EXPECT_TRUE(r.all.disappearances_checked);
    bool object_seen = false;
    for (const Novelty& n : r.all.novelties) {
      const int truth = majority(r.labels, sweep.labels, n.id);
      EXPECT_GT(n.track_id, 0u);
      EXPECT_EQ(n.last_seen, r.all.header.stamp);
      if (truth == sim::kStayingObjectId) {
        object_seen = true;
        if (object_track == 0) object_track = n.track_id;
        EXPECT_EQ(n.track_id, object_track) << "sweep " << k;
        EXPECT_EQ(n.times_seen, static_cast<std::uint32_t>(k + 1));
        EXPECT_EQ(n.confirmed, k >= 1) << "sweep " << k;
        EXPECT_EQ(n.first_seen, ros::Time(1000.0));
      } else if (truth == sim::kWalkingPersonId) {
        ++person_sightings;
        EXPECT_FALSE(n.confirmed) << "the person, sweep " << k;
        EXPECT_EQ(n.times_seen, 1u);
      }
    }
    EXPECT_TRUE(object_seen) << "sweep " << k;
    // The confirmed topic: the object from its second sweep, nothing on the person.
    bool object_confirmed = false;
    for (const Novelty& n : r.confirmed.novelties) {
      EXPECT_TRUE(n.confirmed);
      const int truth = majority(r.labels, sweep.labels, n.id);
      EXPECT_NE(truth, sim::kWalkingPersonId);
      object_confirmed |= n.track_id == object_track;
    }
    EXPECT_EQ(object_confirmed, k >= 1) << "sweep " << k;
  }
  EXPECT_GE(person_sightings, 2) << "the person should be detected as it walks";

  // An ignore region over the object: its points are not compared any more.
  const sim::RouteSweep& last = scene.sequence.back();
  Eigen::AlignedBox3d box;
  for (std::size_t i = 0; i < last.cloud.size(); ++i)
    if (last.labels[i] == sim::kStayingObjectId)
      box.extend(last.cloud[i].getVector3fMap().cast<double>());
  IgnoreRegion region;
  region.centre = box.center();
  region.half_extent = 0.5 * box.sizes() + Eigen::Vector3d::Constant(0.1);
  SetIgnoreRegions ignore;
  ignore.request.regions = formatIgnoreRegions({region});
  ASSERT_TRUE(ros::service::call("/detector/set_ignore_regions", ignore));
  ASSERT_TRUE(ignore.response.success) << ignore.response.message;
  EXPECT_NE(ignore.response.message.find("1 ignore region"), std::string::npos);
  SetIgnoreRegions bad;
  bad.request.regions = "0 0 0 1 1";
  ASSERT_TRUE(ros::service::call("/detector/set_ignore_regions", bad));
  EXPECT_FALSE(bad.response.success);
  EXPECT_NE(bad.response.message.find("preprocess/ignore_regions"), std::string::npos);

  const SweepResult r = publish(last, cfg.sequence_sweeps);
  ASSERT_EQ(r.labels.size(), last.cloud.size());
  std::size_t object_points = 0, object_labelled = 0;
  for (std::size_t i = 0; i < last.cloud.size(); ++i) {
    if (last.labels[i] != sim::kStayingObjectId) continue;
    ++object_points;
    object_labelled += r.labels[i] > 0;
  }
  EXPECT_EQ(object_labelled, 0u);
  EXPECT_GE(r.all.ignored_points, object_points);
  for (const Novelty& n : r.confirmed.novelties) EXPECT_NE(n.track_id, object_track);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_change_tracking");
  ros::NodeHandle keep_alive;
  return RUN_ALL_TESTS();
}
