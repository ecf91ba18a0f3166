// The tiled reference answers while it builds a model: a large map's model takes seconds to
// build and the diagnostics and services read the map meanwhile.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <random>
#include <thread>

#include "novelty_detection/ros/tiled_reference.h"

using namespace novelty_detection;

TEST(TiledReference, AnswersWhileAModelIsBuilt) {
  // A 20 m x 20 m floor with 300,000 noisy points: its model takes a noticeable time.
  Cloud map;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.f, 20.f);
  std::normal_distribution<float> noise(0.f, 0.01f);
  for (int i = 0; i < 300000; ++i) map.push_back(PointT(u(rng), u(rng), noise(rng)));
  TiledReference reference(Params{}, 0.0, 2);
  reference.setMap(map);

  std::atomic<bool> done{false};
  std::thread build([&] {
    reference.pipelineFor(Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(20, 20, 1));
    done = true;
  });
  // While the build runs, every read returns at once.
  int answered_during_build = 0;
  const auto t0 = std::chrono::steady_clock::now();
  while (!done) {
    EXPECT_EQ(reference.mapSize(), map.size());
    // The model enters the cache just before pipelineFor returns and `done` is set: a read in
    // between may see it; never more than the one model.
    EXPECT_LE(reference.cachedModels(), 1u);
    if (!done) ++answered_during_build;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  build.join();
  const double build_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_GT(build_s, 0.1) << "the build must take long enough to be observed";
  EXPECT_GE(answered_during_build, 10) << build_s << " s build";
  EXPECT_EQ(reference.cachedModels(), 1u);
  EXPECT_EQ(reference.modelsBuilt(), 1u);

  // The same tiles again: the cached model, nothing built.
  const auto a = reference.pipelineFor(Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(20, 20, 1));
  const auto b = reference.pipelineFor(Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(20, 20, 1));
  EXPECT_EQ(a, b);
  EXPECT_EQ(reference.modelsBuilt(), 1u);
}

TEST(TiledReference, ReplacingTheMapDropsTheCachedModels) {
  Cloud first, second;
  for (int i = 0; i < 400; ++i) {
    first.push_back(PointT(0.01f * i, 0.f, 0.f));
    second.push_back(PointT(0.01f * i, 1.f, 0.f));
  }
  TiledReference reference(Params{}, 0.0, 2);
  reference.setMap(first);
  reference.pipelineFor(Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(5, 5, 1));
  EXPECT_EQ(reference.cachedModels(), 1u);
  reference.setMap(second);
  EXPECT_EQ(reference.cachedModels(), 0u);
}

TEST(TiledReference, EachCropKeepsTheViewpointsOfItsSweeps) {
  // Two sweeps of a wall, one at x in [0, 2] seen from (1, -3, 1), one at x in [10, 12]
  // seen from (11, -3, 1).
  Cloud map;
  ReferenceViews views;
  views.origins = {Eigen::Vector3f(1, -3, 1), Eigen::Vector3f(11, -3, 1)};
  std::mt19937 rng(5);
  std::normal_distribution<float> noise(0.f, 0.005f);
  for (std::uint32_t k = 0; k < 2; ++k) {
    for (int i = 0; i < 40; ++i) {
      for (int j = 0; j < 40; ++j) {
        map.push_back(PointT(10.f * k + 0.05f * i, noise(rng), 0.05f * j));
        views.sweep.push_back(k);
      }
    }
  }
  TiledReference reference(Params{}, 4.0, 4);
  ReferenceViews bad = views;
  bad.sweep.pop_back();
  EXPECT_THROW(reference.setMap(map, bad), std::invalid_argument);
  reference.setMap(map, views);
  EXPECT_EQ(reference.views().origins.size(), 2u);
  const auto first = reference.pipelineFor(Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(3, 1, 3));
  EXPECT_EQ(first->referenceViewpoints(), 1u);
  EXPECT_EQ(first->referenceCloud().size(), 1600u);
  const auto both = reference.pipelineFor(Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(13, 1, 3));
  EXPECT_EQ(both->referenceViewpoints(), 2u);
  // Without views, a map whose viewpoint is unknown has none.
  reference.setMap(map);
  EXPECT_EQ(reference.pipelineFor(Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(13, 1, 3))
                ->referenceViewpoints(),
            0u);
}
