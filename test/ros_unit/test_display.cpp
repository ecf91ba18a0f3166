// Superquadric marker meshes are closed and wound outwards (rviz shades by winding); the tiled
// reference caches models.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <tuple>

#include "novelty_detection/ros/node_params.h"
#include "novelty_detection/ros/operator_display.h"
#include "novelty_detection/ros/result_messages.h"
#include "novelty_detection/ros/superquadric_mesh.h"
#include "novelty_detection/ros/tiled_reference.h"

using namespace novelty_detection;

namespace {
// Signed volume by the divergence theorem: positive iff triangles are CCW from outside.
double signedVolume(const std::vector<Eigen::Vector3d>& tris) {
  double v = 0.0;
  for (std::size_t i = 0; i + 2 < tris.size(); i += 3) {
    v += tris[i].dot(tris[i + 1].cross(tris[i + 2])) / 6.0;
  }
  return v;
}
}  // namespace

TEST(SuperquadricMesh, EllipsoidVolumeAndOutwardWinding) {
  Superquadric sq;
  sq.a = Eigen::Vector3d(0.3, 0.2, 0.5);
  sq.e1 = sq.e2 = 1.0;
  sq.euler = Eigen::Vector3d(0.4, 0.7, -0.2);
  sq.position = Eigen::Vector3d(1.0, -2.0, 0.5);
  const auto tris = superquadricTriangles(sq, 24);
  ASSERT_EQ(tris.size() % 3, 0u);
  const double exact = 4.0 / 3.0 * M_PI * 0.3 * 0.2 * 0.5;
  EXPECT_NEAR(signedVolume(tris), exact, 0.01 * exact);
}

TEST(SuperquadricMesh, BoxLikeShapeIsClosedAndOutward) {
  Superquadric sq;
  sq.a = Eigen::Vector3d(0.5, 0.4, 0.3);
  sq.e1 = sq.e2 = 0.1;  // nearly a box of volume 8 a1 a2 a3
  const auto tris = superquadricTriangles(sq, 16);
  const double box = 8 * 0.5 * 0.4 * 0.3;
  const double v = signedVolume(tris);
  EXPECT_GT(v, 0.9 * box);
  EXPECT_LT(v, 1.0 * box);
  // Closed: every directed edge is matched by its reverse (vertices are shared exactly).
  using Key = std::tuple<double, double, double, double, double, double>;
  std::map<Key, int> edges;
  for (std::size_t i = 0; i < tris.size(); i += 3) {
    for (int k = 0; k < 3; ++k) {
      const auto& a = tris[i + k];
      const auto& b = tris[i + (k + 1) % 3];
      ++edges[Key(a.x(), a.y(), a.z(), b.x(), b.y(), b.z())];
      --edges[Key(b.x(), b.y(), b.z(), a.x(), a.y(), a.z())];
    }
  }
  for (const auto& e : edges) ASSERT_EQ(e.second, 0);
}

TEST(ResultMessages, MarkersStartWithDeleteAllAndFollowTheResult) {
  Result r;
  Superquadric sq;
  sq.segment = 2;
  r.superquadrics = {sq, sq};
  Gaussian g;
  g.cov = Eigen::Vector3d(0.04, 0.01, 0.0001).asDiagonal();
  r.current_gmm.components = {g, g, g};
  r.novel_gaussian = {false, true, false};
  std_msgs::Header h;
  h.frame_id = "map";
  const auto sqm = superquadricMarkers(r, h);
  ASSERT_EQ(sqm.markers.size(), 3u);
  EXPECT_EQ(sqm.markers[0].action, visualization_msgs::Marker::DELETEALL);
  EXPECT_EQ(sqm.markers[1].type, visualization_msgs::Marker::TRIANGLE_LIST);
  EXPECT_EQ(sqm.markers[1].points.size() % 3, 0u);
  const auto gm = gaussianMarkers(r, r.novel_gaussian, h);
  ASSERT_EQ(gm.markers.size(), 4u);
  EXPECT_EQ(gm.markers[2].ns, "novel_gaussians");
  EXPECT_EQ(gm.markers[1].ns, "gaussians");
  // 2-sigma ellipsoid: diameter 4 sigma along each principal axis (any order).
  const auto& s = gm.markers[1].scale;
  EXPECT_NEAR(s.x + s.y + s.z, 4 * (0.2 + 0.1 + 0.01), 1e-9);
}

// Two novel Gaussians, one holding labelled points and one whose points were all turned
// down, and a non-novel one holding a labelled point: only the first is shown red.
TEST(OperatorDisplay, OnlyNovelGaussiansHoldingLabelledPointsAreRed) {
  Result r;
  Gaussian a, b, c;
  a.weight = b.weight = c.weight = 1.0 / 3;
  a.mean = Eigen::Vector3d(0, 0, 0);
  b.mean = Eigen::Vector3d(5, 0, 0);
  c.mean = Eigen::Vector3d(0, 5, 0);
  a.cov = b.cov = c.cov = Eigen::Matrix3d::Identity() * 0.01;
  r.current_gmm.components = {a, b, c};
  r.novel_gaussian = {true, true, false};
  Cloud cloud;
  cloud.push_back(PointT(0.05f, 0.0f, 0.0f));  // a's, labelled
  cloud.push_back(PointT(5.0f, 0.05f, 0.0f));  // b's, not labelled
  cloud.push_back(PointT(0.0f, 4.95f, 0.0f));  // c's, labelled (not novel)
  cloud.push_back(PointT(NAN, NAN, NAN));      // labelled but not a point
  r.labels = {1, 0, 2, 1};
  const std::vector<bool> red = gaussiansHoldingNovelPoints(r, cloud);
  EXPECT_EQ(red, (std::vector<bool>{true, false, false}));
  std_msgs::Header h;
  const auto gm = gaussianMarkers(r, red, h);
  ASSERT_EQ(gm.markers.size(), 4u);
  EXPECT_EQ(gm.markers[1].ns, "novel_gaussians");
  EXPECT_EQ(gm.markers[2].ns, "gaussians");
  EXPECT_EQ(gm.markers[3].ns, "gaussians");
  // No labelled point: nothing is red whatever the selection said.
  r.labels = {0, 0, 0, 0};
  EXPECT_EQ(gaussiansHoldingNovelPoints(r, cloud), (std::vector<bool>(3, false)));
  // Labels that do not match the cloud: nothing is claimed.
  r.labels = {1};
  EXPECT_EQ(gaussiansHoldingNovelPoints(r, cloud), (std::vector<bool>(3, false)));
}

TEST(OperatorDisplay, TextPerNoveltyAndOutlinePerDisappearance) {
  NoveltyArray array;
  array.header.frame_id = "map";
  Novelty n;
  n.id = 3;
  n.points = 252;
  n.bbox_min.x = 5.5;
  n.bbox_min.y = -0.7;
  n.bbox_min.z = 0.1;
  n.bbox_max.x = 5.9;
  n.bbox_max.y = 0.1;
  n.bbox_max.z = 0.7;
  array.novelties.push_back(n);
  n.id = 4;
  n.confirmed = true;
  n.times_seen = 4;
  array.novelties.push_back(n);
  Novelty bad = n;
  bad.bbox_max.x = NAN;  // a box that is not one gets no marker
  array.novelties.push_back(bad);
  Novelty gone = n;
  gone.id = 1;
  gone.points = 90;
  array.disappeared.push_back(gone);
  EXPECT_EQ(noveltyLabel(array.novelties[0], false), "#3 new: 0.40 x 0.80 x 0.60 m, 252 pts");
  EXPECT_EQ(noveltyLabel(array.novelties[1], false),
            "#4 confirmed (seen 4): 0.40 x 0.80 x 0.60 m, 252 pts");
  EXPECT_EQ(noveltyLabel(gone, true), "#1 gone: 0.40 x 0.80 x 0.60 m, 90 pts");

  const auto m = noveltyLabelMarkers(array);
  ASSERT_EQ(m.markers.size(), 5u);  // DELETEALL, 2 texts, a disappearance's text and box
  EXPECT_EQ(m.markers[0].action, visualization_msgs::Marker::DELETEALL);
  EXPECT_EQ(m.markers[1].ns, "novelty_text");
  EXPECT_EQ(m.markers[1].type, visualization_msgs::Marker::TEXT_VIEW_FACING);
  EXPECT_NEAR(m.markers[1].pose.position.x, 5.7, 1e-9);
  // Letters a quarter of the largest extent high (0.8 m: 0.2, capped at 0.18), one letter
  // above the box; a 12 cm tabletop object gets the 5 cm floor.
  EXPECT_NEAR(m.markers[1].scale.z, 0.18, 1e-9);
  EXPECT_NEAR(m.markers[1].pose.position.z, 0.7 + 0.18, 1e-9);
  NoveltyArray small;
  Novelty mug;
  mug.bbox_max.x = mug.bbox_max.y = 0.08;
  mug.bbox_max.z = 0.12;
  small.novelties.push_back(mug);
  const auto s = noveltyLabelMarkers(small);
  ASSERT_EQ(s.markers.size(), 2u);
  EXPECT_NEAR(s.markers[1].scale.z, 0.05, 1e-9);
  EXPECT_NEAR(s.markers[1].pose.position.z, 0.17, 1e-9);
  // Up along -y (a camera's optical frame): above is -y, beside the box's centre.
  const auto cam = noveltyLabelMarkers(small, Eigen::Vector3d(0, -2, 0));
  EXPECT_NEAR(cam.markers[1].pose.position.y, 0.04 - 0.04 - 0.05, 1e-9);
  EXPECT_NEAR(cam.markers[1].pose.position.z, 0.06, 1e-9);
  // The text takes the colour of its segment's points and superquadrics.
  // (a light tint of it, readable on a dark background).
  EXPECT_FLOAT_EQ(m.markers[2].color.r, 0.5f * (segmentColour(4).r + 1.0f));
  EXPECT_FLOAT_EQ(m.markers[2].color.g, 0.5f * (segmentColour(4).g + 1.0f));
  EXPECT_EQ(m.markers[3].ns, "disappeared_text");
  EXPECT_NEAR(m.markers[3].pose.position.z, 0.1 - 0.18, 1e-9);  // below its box
  const auto& box = m.markers[4];
  EXPECT_EQ(box.ns, "disappeared_box");
  EXPECT_EQ(box.type, visualization_msgs::Marker::LINE_LIST);
  ASSERT_EQ(box.points.size(), 24u);  // 12 edges
  // Every edge runs along one axis, the length of the box along it.
  double total = 0.0;
  for (std::size_t i = 0; i < 24; i += 2) {
    const double dx = std::abs(box.points[i + 1].x - box.points[i].x);
    const double dy = std::abs(box.points[i + 1].y - box.points[i].y);
    const double dz = std::abs(box.points[i + 1].z - box.points[i].z);
    EXPECT_EQ((dx > 0) + (dy > 0) + (dz > 0), 1);
    total += dx + dy + dz;
  }
  EXPECT_NEAR(total, 4 * (0.4 + 0.8 + 0.6), 1e-9);
}

TEST(TiledReference, CachesOneModelPerSetOfTiles) {
  Params params;
  TiledReference ref(params, 2.0, 2);
  Cloud map;
  for (int i = 0; i < 100; ++i) {
    // A wall (x 0..9.9, y ~ 0.5, z 0.2..1.1), not ground: the pipeline removes the floor.
    for (int j = 0; j < 10; ++j) {
      map.push_back(PointT(0.1f * i, 0.5f + 0.01f * std::sin(0.7f * i * j), 0.2f + 0.1f * j));
    }
  }
  EXPECT_THROW(ref.pipelineFor(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones()), std::logic_error);
  ref.setMap(map);
  const auto a = ref.pipelineFor(Eigen::Vector3d(0.5, 0, 0), Eigen::Vector3d(1.5, 1, 1));
  EXPECT_EQ(a->referenceCloud().size(), 200u);  // tile x in [0, 2)
  const auto b = ref.pipelineFor(Eigen::Vector3d(0.1, 0, 0), Eigen::Vector3d(1.9, 1, 1));
  EXPECT_EQ(a.get(), b.get());  // same tiles: cached
  const auto c = ref.pipelineFor(Eigen::Vector3d(1.5, 0, 0), Eigen::Vector3d(4.5, 1, 1));
  EXPECT_EQ(c->referenceCloud().size(), 600u);  // tiles [0,2), [2,4), [4,6)
  EXPECT_EQ(ref.modelsBuilt(), 2u);
  EXPECT_THROW(ref.pipelineFor(Eigen::Vector3d(50, 50, 0), Eigen::Vector3d(51, 51, 1)),
               std::runtime_error);
  Cloud nan_map;
  nan_map.push_back(PointT(NAN, 0, 0));
  EXPECT_THROW(ref.setMap(nan_map), std::invalid_argument);
  EXPECT_EQ(ref.mapSize(), 1000u);  // a refused map leaves the old one
  // A box reaching absurdly far (a stray point near -9.2e19 m, a huge margin) neither
  // overflows the tile index nor walks empty tiles: it answers at once.
  const auto far = ref.pipelineFor(Eigen::Vector3d(-9.3e19, -1e20, 0), Eigen::Vector3d(1.5, 1, 1));
  EXPECT_EQ(far->referenceCloud().size(), 200u);
  EXPECT_THROW(ref.pipelineFor(Eigen::Vector3d(-1e30, -1e30, 0), Eigen::Vector3d(-1e29, -1e29, 1)),
               std::runtime_error);
  Cloud absurd = map;
  absurd.push_back(PointT(-9.3e19f, 0.5f, 0.5f));
  ref.setMap(absurd);  // the absurd point is no tile
  EXPECT_EQ(ref.pipelineFor(Eigen::Vector3d(0.5, 0, 0), Eigen::Vector3d(1.5, 1, 1))
                ->referenceCloud()
                .size(),
            200u);
}

TEST(NodeParams, MarginAndTileSizeOutOfRangeAreRefused) {
  NodeParams p;
  EXPECT_NO_THROW(p.validate());
  p.crop_margin_m = 1e20;  // accepted once: every sweep's box then spun over int64 tiles
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p.crop_margin_m = 10000.0;
  EXPECT_NO_THROW(p.validate());
  p.tile_size_m = 1e-30;
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p.tile_size_m = 0.0;  // no tiles
  EXPECT_NO_THROW(p.validate());
  for (double bad : {-0.05, 1e-4, 1e3, double(NAN)}) {
    p.reference_display_voxel_m = bad;
    EXPECT_THROW(p.validate(), std::invalid_argument) << bad;
  }
  p.reference_display_voxel_m = 0.0;  // every point
  EXPECT_NO_THROW(p.validate());
}
