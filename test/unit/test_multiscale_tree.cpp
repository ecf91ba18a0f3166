// Multi-scale tree (Pauly et al. 2002 hierarchical clustering): structure, known surface
// variations, cuts that partition the input, monotone scales, degenerate inputs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <stdexcept>

#include "novelty_detection/preprocess/multiscale_tree.h"
#include "synthetic_scene.h"

namespace nd = novelty_detection;
using Tree = nd::MultiScaleTree;

namespace {

/// n points uniform on the unit square of the plane z = 0, moved by `offset`.
nd::Cloud plane(int n, unsigned seed, const Eigen::Vector3f& offset = Eigen::Vector3f::Zero()) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  nd::Cloud c;
  for (int k = 0; k < n; ++k) {
    c.push_back(nd::PointT(offset.x() + u(rng), offset.y() + u(rng), offset.z()));
  }
  return c;
}

/// The corner of a unit cube: n points on each of the faces x = 0, y = 0, z = 0.
nd::Cloud corner(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  nd::Cloud c;
  for (int k = 0; k < n; ++k) c.push_back(nd::PointT(0, u(rng), u(rng)));
  for (int k = 0; k < n; ++k) c.push_back(nd::PointT(u(rng), 0, u(rng)));
  for (int k = 0; k < n; ++k) c.push_back(nd::PointT(u(rng), u(rng), 0));
  return c;
}

/// Checks that the cut partitions the tree's points and agrees with the nodes.
void expectPartition(const Tree& tree, const nd::Cloud& cloud, const Tree::Cut& cut, int n_max,
                     double sigma_max, bool pauly_scale = true) {
  ASSERT_EQ(cut.cluster_of.size(), cloud.size());
  ASSERT_EQ(cut.points.size(), cut.nodes.size());
  ASSERT_EQ(cut.sizes.size(), cut.nodes.size());
  std::vector<int> count(cut.nodes.size(), 0);
  std::vector<Eigen::Vector3d> sum(cut.nodes.size(), Eigen::Vector3d::Zero());
  std::vector<char> in_tree(cloud.size(), 0);
  for (int i : tree.order()) in_tree[i] = 1;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const int c = cut.cluster_of[i];
    if (!in_tree[i]) {
      EXPECT_EQ(c, -1);
      continue;
    }
    ASSERT_GE(c, 0);
    ASSERT_LT(c, static_cast<int>(cut.nodes.size()));
    ++count[c];
    sum[c] += cloud[i].getVector3fMap().cast<double>();
  }
  long total = 0;
  for (std::size_t c = 0; c < cut.nodes.size(); ++c) {
    const Tree::Node& node = tree.nodes()[cut.nodes[c]];
    EXPECT_EQ(count[c], cut.sizes[c]);
    EXPECT_EQ(node.size(), cut.sizes[c]);
    total += cut.sizes[c];
    EXPECT_LT((sum[c] / count[c] - cut.points[c].cast<double>()).norm(), 1e-4);
    // A cluster satisfies the scale (or is a leaf), and its parent did not.
    if (!pauly_scale) continue;
    EXPECT_TRUE(node.isLeaf() || (node.size() <= n_max && node.sigma <= sigma_max));
    if (node.parent >= 0) {
      const Tree::Node& parent = tree.nodes()[node.parent];
      EXPECT_TRUE(parent.size() > n_max || parent.sigma > sigma_max);
    }
  }
  EXPECT_EQ(total, static_cast<long>(tree.order().size()));
}

}  // namespace

TEST(MultiScaleTree, PlaneIsFlatAndNotSplitBelowNMax) {
  const nd::Cloud cloud = plane(1000, 1);
  Tree tree;
  tree.build(cloud);
  ASSERT_FALSE(tree.nodes().empty());
  for (const auto& node : tree.nodes()) EXPECT_LT(node.sigma, 1e-6);
  // The whole plane is one cluster when n_max allows it ...
  const Tree::Cut whole = tree.cut(1000, 0.01);
  ASSERT_EQ(whole.nodes.size(), 1u);
  EXPECT_EQ(whole.sizes[0], 1000);
  EXPECT_LT((whole.points[0] - Eigen::Vector3f(0.5f, 0.5f, 0.f)).norm(), 0.03f);
  // ... and with n_max = 100 every cluster is a maximal node of <= 100 points: halving the
  // plane along its widest direction gives clusters of 63 +- a few points (1000 / 16).
  const Tree::Cut c100 = tree.cut(100, 0.01);
  expectPartition(tree, cloud, c100, 100, 0.01);
  for (int s : c100.sizes) {
    EXPECT_LE(s, 100);
    EXPECT_GT(s, 30);
  }
  EXPECT_GE(c100.nodes.size(), 10u);
  EXPECT_LE(c100.nodes.size(), 32u);
}

TEST(MultiScaleTree, NodesHoldTheirPointsMomentsAndLinks) {
  const nd::Cloud cloud = corner(300, 2);
  Tree tree;
  tree.build(cloud);
  std::vector<int> sorted = tree.order();
  std::sort(sorted.begin(), sorted.end());
  for (int i = 0; i < static_cast<int>(cloud.size()); ++i) ASSERT_EQ(sorted[i], i);
  const auto& nodes = tree.nodes();
  EXPECT_EQ(nodes[0].begin, 0);
  EXPECT_EQ(nodes[0].end, 900);
  for (std::size_t id = 0; id < nodes.size(); ++id) {
    const Tree::Node& n = nodes[id];
    if (n.isLeaf()) {
      EXPECT_LE(n.size(), Tree::kMaxLeafSize);
      EXPECT_GE(n.size(), 1);
    } else {
      const Tree::Node& l = nodes[n.left];
      const Tree::Node& r = nodes[n.right];
      EXPECT_EQ(l.begin, n.begin);
      EXPECT_EQ(l.end, r.begin);
      EXPECT_EQ(r.end, n.end);
      EXPECT_EQ(l.parent, static_cast<int>(id));
      EXPECT_EQ(r.parent, static_cast<int>(id));
    }
    // Centroid and covariance against a direct two-pass computation.
    const nd::Indices idx = tree.nodeIndices(static_cast<int>(id));
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (int i : idx) mean += cloud[i].getVector3fMap().cast<double>();
    mean /= idx.size();
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (int i : idx) {
      const Eigen::Vector3d d = cloud[i].getVector3fMap().cast<double>() - mean;
      cov += d * d.transpose();
    }
    cov /= idx.size();
    EXPECT_LT((mean - n.centroid.cast<double>()).norm(), 1e-5);
    EXPECT_LT((cov - n.covariance.cast<double>()).norm(), 1e-5);
  }
  EXPECT_THROW(tree.nodeIndices(-1), std::out_of_range);
  EXPECT_THROW(tree.nodeIndices(static_cast<int>(nodes.size())), std::out_of_range);
}

TEST(MultiScaleTree, CornerIsSplitAndStaysDenserThanFaces) {
  const nd::Cloud cloud = corner(2000, 3);
  Tree tree;
  tree.build(cloud);
  // Three orthogonal unit squares: no direction is thin, far from flat (sigma <= 1/3).
  EXPECT_GT(tree.nodes()[0].sigma, 0.15);
  const double sigma_max = 0.01;
  const Tree::Cut cut = tree.cut(1 << 20, sigma_max);  // size never forces a split
  expectPartition(tree, cloud, cut, 1 << 20, sigma_max);
  ASSERT_GT(cut.nodes.size(), 3u);
  // Clusters touching two faces (along the edges) are small; clusters inside a face large.
  double edge_sum = 0, face_sum = 0;
  int edge_n = 0, face_n = 0;
  for (std::size_t c = 0; c < cut.nodes.size(); ++c) {
    const Eigen::Vector3f p = cut.points[c];
    const int near_faces = (p.x() < 0.05f) + (p.y() < 0.05f) + (p.z() < 0.05f);
    // A centroid within 5 cm of two faces sits on an edge cluster.
    if (near_faces >= 2) {
      edge_sum += cut.sizes[c];
      ++edge_n;
    } else if ((p.array() > 0.3f || p.array() < 0.01f).all() && near_faces == 1) {
      face_sum += cut.sizes[c];
      ++face_n;
    }
  }
  ASSERT_GT(edge_n, 0);
  ASSERT_GT(face_n, 0);
  EXPECT_LT(edge_sum / edge_n, 0.2 * face_sum / face_n)
      << "edge clusters " << edge_n << " mean " << edge_sum / edge_n << ", face clusters " << face_n
      << " mean " << face_sum / face_n;
}

TEST(MultiScaleTree, RightAngleEdgeIsSplitIntoItsFaces) {
  // Two unit squares meeting at a right angle along the z axis (x = 0 and y = 0 faces).
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  nd::Cloud cloud;
  for (int k = 0; k < 1500; ++k) cloud.push_back(nd::PointT(0, u(rng), u(rng)));
  for (int k = 0; k < 1500; ++k) cloud.push_back(nd::PointT(u(rng), 0, u(rng)));
  Tree tree;
  tree.build(cloud);
  // Covariance eigenvalues of the L: 1/24 along (1,1,0), 1/12 along z, 1/6 along (1,-1,0):
  // sigma = 1/7. The split normal to (1,-1,0) through the centroid separates the faces.
  EXPECT_NEAR(tree.nodes()[0].sigma, 1.0 / 7.0, 0.01);
  const Tree::Cut cut = tree.cut(1 << 20, 0.01);
  expectPartition(tree, cloud, cut, 1 << 20, 0.01);
  ASSERT_EQ(cut.nodes.size(), 2u);
  for (const int node : cut.nodes) EXPECT_LT(tree.nodes()[node].sigma, 1e-4);
  // One face each, but for points within the sampling offset of the centroid from the
  // edge's bisector, which can fall on the other side.
  const int face_of_x0 = cut.cluster_of[0];
  for (int i = 0; i < 3000; ++i) {
    const bool on_x0 = i < 1500;
    const float from_edge = on_x0 ? cloud[i].y : cloud[i].x;
    if (from_edge > 0.03f) {
      EXPECT_EQ(cut.cluster_of[i] == face_of_x0, on_x0) << "point " << i;
    }
  }
}

TEST(MultiScaleTree, CutSizesShrinkAsScaleGrows) {
  novelty_detection::synthetic::SceneOptions opt;
  opt.points = 20000;
  opt.range_sigma_m = 0.01;
  opt.nan_fraction = 0.01;
  const auto scene = novelty_detection::synthetic::makeCorridor(opt);
  Tree tree;
  tree.build(scene.cloud);
  std::size_t previous = std::numeric_limits<std::size_t>::max();
  for (const double s : {0.0, 0.001, 0.003, 0.01, 0.02, 0.05, 0.1, 0.2, 1.0 / 3.0}) {
    const Tree::Cut cut = tree.cut(64, s);
    expectPartition(tree, scene.cloud, cut, 64, s);
    EXPECT_LE(cut.nodes.size(), previous) << "sigma_max " << s;
    previous = cut.nodes.size();
  }
  previous = std::numeric_limits<std::size_t>::max();
  std::size_t first = 0;
  for (const int n : {1, 2, 4, 8, 16, 32, 64, 256, 1 << 20}) {
    const Tree::Cut cut = tree.cut(n, 0.05);
    expectPartition(tree, scene.cloud, cut, n, 0.05);
    EXPECT_LE(cut.nodes.size(), previous) << "n_max " << n;
    if (!first) first = cut.nodes.size();
    previous = cut.nodes.size();
  }
  EXPECT_LT(previous, first / 4);  // the range of scales is wide
  // The finest cut is the leaves: clusters of at most kMaxLeafSize points.
  const Tree::Cut finest = tree.cut(1, 0.0);
  EXPECT_GE(finest.nodes.size(), tree.order().size() / Tree::kMaxLeafSize);
}

TEST(MultiScaleTree, SubsetsNaNsAndBadIndices) {
  nd::Cloud cloud = plane(200, 4);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cloud[5] = nd::PointT(nan, 0, 0);
  Tree tree;
  tree.build(cloud);  // all finite points
  EXPECT_EQ(tree.order().size(), 199u);
  EXPECT_EQ(tree.cut(8, 0.0).cluster_of[5], -1);
  nd::Indices even;
  for (int i = 0; i < 200; i += 2) even.push_back(i);
  tree.build(cloud, even);  // the NaN at 5 is not selected; all selected are finite
  EXPECT_EQ(tree.order().size(), 100u);
  const Tree::Cut cut = tree.cut(8, 0.0);
  expectPartition(tree, cloud, cut, 8, 0.0);
  EXPECT_EQ(cut.cluster_of[1], -1);
  EXPECT_GE(cut.cluster_of[2], 0);
  EXPECT_THROW(tree.build(cloud, {0, 1, 1}), std::invalid_argument);
  EXPECT_THROW(tree.build(cloud, {0, 200}), std::invalid_argument);
  EXPECT_THROW(tree.build(cloud, {-1}), std::invalid_argument);
  tree.build(cloud);
  EXPECT_THROW(tree.cut(0, 0.1), std::invalid_argument);
  EXPECT_THROW(tree.cut(8, -0.1), std::invalid_argument);
  EXPECT_THROW(tree.cut(8, std::nan("")), std::invalid_argument);
}

TEST(MultiScaleTree, DegenerateGeometry) {
  Tree tree;
  nd::Cloud empty;
  tree.build(empty);
  EXPECT_TRUE(tree.nodes().empty());
  EXPECT_TRUE(tree.cut(8, 0.1).nodes.empty());

  nd::Cloud one;
  one.push_back(nd::PointT(1, 2, 3));
  tree.build(one);
  ASSERT_EQ(tree.nodes().size(), 1u);
  EXPECT_EQ(tree.nodes()[0].sigma, 0.f);
  EXPECT_EQ(tree.cut(1, 0.0).cluster_of, (std::vector<int>{0}));

  nd::Cloud dup;  // 100 copies of one point: one leaf, no endless splitting
  for (int k = 0; k < 100; ++k) dup.push_back(nd::PointT(3.3f, -1.7f, 1e3f));
  tree.build(dup);
  ASSERT_EQ(tree.nodes().size(), 1u);
  EXPECT_EQ(tree.cut(1, 0.0).sizes, (std::vector<int>{100}));

  nd::Cloud line;  // collinear: sigma 0 everywhere, split down to small leaves
  for (int k = 0; k < 100; ++k) line.push_back(nd::PointT(0.01f * k, 0, 0));
  tree.build(line);
  for (const auto& n : tree.nodes()) {
    EXPECT_EQ(n.sigma, 0.f);
    if (n.isLeaf()) {
      EXPECT_LE(n.size(), Tree::kMaxLeafSize);
    }
  }
  // Mixed duplicates and distinct points terminate too.
  nd::Cloud mixed = dup;
  mixed.push_back(nd::PointT(3.3f, -1.7f, 1e3f + 1.f));
  tree.build(mixed);
  EXPECT_EQ(tree.cut(1, 0.0).sizes.size(), 2u);

  // Far from the origin the covariance does not cancel: a plane stays flat.
  const nd::Cloud far = plane(500, 9, Eigen::Vector3f(1e4f, -1e4f, 300.f));
  tree.build(far);
  EXPECT_LT(tree.nodes()[0].sigma, 1e-5);
  EXPECT_EQ(tree.cut(500, 1e-3).nodes.size(), 1u);
}

TEST(MultiScaleTree, NoiseEstimateAndNoiseAwareCut) {
  // A 2 m x 2 m floor with 1 cm Gaussian noise in z.
  std::mt19937 rng(12);
  std::uniform_real_distribution<float> u(0.f, 2.f);
  std::normal_distribution<float> n(0.f, 0.01f);
  nd::Cloud cloud;
  for (int k = 0; k < 20000; ++k) cloud.push_back(nd::PointT(u(rng), u(rng), n(rng)));
  Tree tree;
  tree.build(cloud);
  EXPECT_NEAR(tree.noiseVariance(), 1e-4, 0.15e-4);
  // Pauly's rule reads the noise as curvature and splits far below n_max; the noise-aware
  // rule keeps clusters of up to n_max points.
  const Tree::Cut pauly = tree.cut(64, 0.01);
  const Tree::Cut aware = tree.cut(64, 0.01, 2.0 * tree.noiseVariance());
  expectPartition(tree, cloud, aware, 64, 0.01, false);
  EXPECT_GT(pauly.nodes.size(), 2 * aware.nodes.size());
  EXPECT_LT(aware.nodes.size(), 20000u / 20);
  // noise 0 is Pauly's rule exactly; more discounted noise never refines the cut.
  EXPECT_EQ(tree.cut(64, 0.01, 0.0).nodes, pauly.nodes);
  std::size_t previous = pauly.nodes.size();
  for (const double v : {1e-5, 1e-4, 2e-4, 1e-3}) {
    const std::size_t size = tree.cut(64, 0.01, v).nodes.size();
    EXPECT_LE(size, previous);
    previous = size;
  }
  nd::MultiScaleParams p;
  EXPECT_EQ(tree.cut(p).nodes,
            tree.cut(p.n_max, p.sigma_max, p.noise_factor * tree.noiseVariance()).nodes);
  p.noise_aware = false;
  EXPECT_EQ(tree.cut(p).nodes, tree.cut(p.n_max, p.sigma_max).nodes);
  EXPECT_THROW(tree.cut(8, 0.01, -1.0), std::invalid_argument);
}

// On two threads the subtrees below the top levels grow at once, largest first, and are
// numbered as the serial build numbers them: the same nodes (ranges, links, statistics), the
// same order, the same cuts. Also when a node above those levels is a leaf (a pile of
// duplicates that no split separates).
namespace {

void expectSameTree(const nd::Cloud& cloud) {
  Tree serial, parallel;
  serial.build(cloud, {}, 1);
  parallel.build(cloud, {}, 2);
  ASSERT_GT(serial.nodes().size(), 1000u);
  ASSERT_EQ(serial.nodes().size(), parallel.nodes().size());
  EXPECT_EQ(serial.order(), parallel.order());
  for (std::size_t k = 0; k < serial.nodes().size(); ++k) {
    const Tree::Node &a = serial.nodes()[k], &b = parallel.nodes()[k];
    ASSERT_EQ(a.begin, b.begin) << "node " << k;
    ASSERT_EQ(a.end, b.end) << "node " << k;
    ASSERT_EQ(a.left, b.left) << "node " << k;
    ASSERT_EQ(a.right, b.right) << "node " << k;
    ASSERT_EQ(a.parent, b.parent) << "node " << k;
    ASSERT_EQ(a.centroid, b.centroid) << "node " << k;
    ASSERT_EQ(a.covariance, b.covariance) << "node " << k;
    ASSERT_EQ(a.sigma, b.sigma) << "node " << k;
  }
  EXPECT_EQ(serial.noiseVariance(), parallel.noiseVariance());
  EXPECT_EQ(serial.cut(64, 0.05).nodes, parallel.cut(64, 0.05).nodes);
}

}  // namespace

TEST(MultiScaleTree, TwoThreadsBuildTheSameTree) {
  nd::Cloud cloud = corner(12000, 21);
  for (const auto& p : plane(8000, 22, Eigen::Vector3f(2.f, 0.f, 0.5f))) cloud.push_back(p);
  cloud.push_back(nd::PointT(std::nanf(""), 0.f, 0.f));
  for (int k = 0; k < 20; ++k) cloud.push_back(cloud[static_cast<std::size_t>(k)]);  // repeats
  expectSameTree(cloud);

  // Most points on one spot far to one side: the root's split leaves the pile as a leaf
  // next to the root, above the levels the threads start from.
  nd::Cloud piled = plane(6000, 23);
  for (int k = 0; k < 18000; ++k) piled.push_back(nd::PointT(5.f, 5.f, 5.f));
  Tree tree;
  tree.build(piled, {}, 1);
  const auto& nodes = tree.nodes();
  const auto pile = std::find_if(nodes.begin(), nodes.end(), [](const Tree::Node& n) {
    return n.isLeaf() && n.size() == 18000;
  });
  ASSERT_NE(pile, nodes.end());
  EXPECT_LE(pile - nodes.begin(), 6);  // within the top three levels
  expectSameTree(piled);
}
