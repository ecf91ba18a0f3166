#include "novelty_detection/ros/result_messages.h"

#include <ros/time.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>

#include "novelty_detection/ros/superquadric_mesh.h"

namespace novelty_detection {
namespace {

geometry_msgs::Point toPoint(const Eigen::Vector3d& v) {
  geometry_msgs::Point p;
  p.x = v.x();
  p.y = v.y();
  p.z = v.z();
  return p;
}

geometry_msgs::Quaternion toQuaternion(const Eigen::Quaterniond& q) {
  geometry_msgs::Quaternion m;
  m.x = q.x();
  m.y = q.y();
  m.z = q.z();
  m.w = q.w();
  return m;
}

visualization_msgs::Marker deleteAll(const std_msgs::Header& header) {
  visualization_msgs::Marker m;
  m.header = header;
  m.action = visualization_msgs::Marker::DELETEALL;
  return m;
}

}  // namespace

SuperquadricPart toSuperquadricMsg(const Superquadric& sq) {
  SuperquadricPart m;
  m.segment = sq.segment;
  for (int k = 0; k < 3; ++k) {
    m.a[k] = sq.a[k];
    m.euler[k] = sq.euler[k];
  }
  m.e1 = sq.e1;
  m.e2 = sq.e2;
  m.pose.position = toPoint(sq.position);
  m.pose.orientation = toQuaternion(sq.quaternion());
  m.points = static_cast<std::uint32_t>(std::max(sq.points, 0));
  m.residual = sq.residual;
  return m;
}

namespace {

Novelty toNoveltyMsg(const Segment& seg, const std::vector<Superquadric>& superquadrics) {
  Novelty n;
  n.id = seg.id;
  n.points = static_cast<std::uint32_t>(seg.indices.size());
  n.centroid = toPoint(seg.centroid);
  n.bbox_min = toPoint(seg.bbox_min);
  n.bbox_max = toPoint(seg.bbox_max);
  n.emd_contribution = seg.emd_contribution;
  for (const auto& sq : superquadrics) {
    if (sq.segment == seg.id) n.superquadrics.push_back(toSuperquadricMsg(sq));
  }
  return n;
}

}  // namespace

NoveltyArray toNoveltyArray(const Result& result, const std_msgs::Header& header,
                            double processing_time_s) {
  NoveltyArray out;
  out.header = header;
  out.emd_before = result.emd_before;
  out.emd_after = result.emd_after;
  out.processing_time = processing_time_s;
  const AlignmentResult& a = result.alignment;
  out.alignment_applied = a.applied;
  out.alignment_status = a.status;
  const Eigen::Quaterniond q(a.correction.rotation());
  out.alignment_correction.translation.x = a.correction.translation().x();
  out.alignment_correction.translation.y = a.correction.translation().y();
  out.alignment_correction.translation.z = a.correction.translation().z();
  out.alignment_correction.rotation.x = q.x();
  out.alignment_correction.rotation.y = q.y();
  out.alignment_correction.rotation.z = q.z();
  out.alignment_correction.rotation.w = q.w();
  out.alignment_fitness = a.fitness_m;
  for (const auto& seg : result.segments)
    out.novelties.push_back(toNoveltyMsg(seg, result.superquadrics));
  std::uint32_t nv = 0;
  for (auto f : result.newly_visible) nv += f != 0;
  out.newly_visible_points = nv;
  out.visibility_checked = result.visibility_checked;
  out.disappearances_checked = result.disappearances_checked;
  out.ignored_points = static_cast<std::uint32_t>(result.ignored_points);
  out.ignored_disappearances = static_cast<std::uint32_t>(result.ignored_disappearances);
  for (const auto& seg : result.disappeared_segments)
    out.disappeared.push_back(toNoveltyMsg(seg, result.disappeared_superquadrics));
  return out;
}

namespace {

void setTracks(std::vector<Novelty>& entries, const std::vector<const ChangeTrack*>& tracks) {
  for (std::size_t i = 0; i < entries.size() && i < tracks.size(); ++i) {
    const ChangeTrack* t = tracks[i];
    if (!t) continue;
    entries[i].track_id = t->id;
    entries[i].times_seen = static_cast<std::uint32_t>(std::max(t->times_seen, 0));
    entries[i].first_seen = ros::Time(std::max(t->first_seen, 0.0));
    entries[i].last_seen = ros::Time(std::max(t->last_seen, 0.0));
    entries[i].confirmed = t->confirmed;
  }
}

}  // namespace

void setTracks(NoveltyArray& array, const std::vector<const ChangeTrack*>& novelty_tracks,
               const std::vector<const ChangeTrack*>& disappeared_tracks) {
  setTracks(array.novelties, novelty_tracks);
  setTracks(array.disappeared, disappeared_tracks);
}

NoveltyArray confirmedOnly(const NoveltyArray& array) {
  NoveltyArray out = array;
  auto keep = [](std::vector<Novelty>& v) {
    v.erase(std::remove_if(v.begin(), v.end(), [](const Novelty& n) { return !n.confirmed; }),
            v.end());
  };
  keep(out.novelties);
  keep(out.disappeared);
  return out;
}

std_msgs::ColorRGBA segmentColour(int segment, float alpha) {
  // Hue steps of the golden ratio keep neighbouring ids far apart on the colour wheel.
  const double h = std::fmod(0.1 + 0.618033988749895 * std::max(segment, 0), 1.0) * 6.0;
  const double s = 0.75, v = 0.95;
  const int i = static_cast<int>(h) % 6;
  const double f = h - std::floor(h);
  const double p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
  double r = v, g = t, b = p;
  switch (i) {
    case 1:
      r = q;
      g = v;
      b = p;
      break;
    case 2:
      r = p;
      g = v;
      b = t;
      break;
    case 3:
      r = p;
      g = q;
      b = v;
      break;
    case 4:
      r = t;
      g = p;
      b = v;
      break;
    case 5:
      r = v;
      g = p;
      b = q;
      break;
    default:
      break;
  }
  std_msgs::ColorRGBA c;
  c.r = static_cast<float>(r);
  c.g = static_cast<float>(g);
  c.b = static_cast<float>(b);
  c.a = alpha;
  return c;
}

visualization_msgs::MarkerArray superquadricMarkers(const Result& result,
                                                    const std_msgs::Header& header) {
  visualization_msgs::MarkerArray out;
  out.markers.push_back(deleteAll(header));
  for (std::size_t i = 0; i < result.superquadrics.size(); ++i) {
    const auto& sq = result.superquadrics[i];
    visualization_msgs::Marker m;
    m.header = header;
    m.ns = "superquadrics";
    m.id = static_cast<int>(i);
    m.type = visualization_msgs::Marker::TRIANGLE_LIST;
    m.action = visualization_msgs::Marker::ADD;
    m.pose.orientation.w = 1.0;  // vertices are already in the fixed frame
    m.scale.x = m.scale.y = m.scale.z = 1.0;
    m.color = segmentColour(sq.segment);
    for (const auto& v : superquadricTriangles(sq)) {
      if (!v.allFinite()) continue;
      m.points.push_back(toPoint(v));
    }
    if (!m.points.empty()) out.markers.push_back(m);
  }
  // Disappearances: the missing reference structure, translucent dark red, own namespace.
  for (std::size_t i = 0; i < result.disappeared_superquadrics.size(); ++i) {
    const auto& sq = result.disappeared_superquadrics[i];
    visualization_msgs::Marker m;
    m.header = header;
    m.ns = "disappeared";
    m.id = static_cast<int>(i);
    m.type = visualization_msgs::Marker::TRIANGLE_LIST;
    m.action = visualization_msgs::Marker::ADD;
    m.pose.orientation.w = 1.0;
    m.scale.x = m.scale.y = m.scale.z = 1.0;
    m.color.r = 0.6f;
    m.color.g = 0.05f;
    m.color.b = 0.1f;
    m.color.a = 0.5f;
    for (const auto& v : superquadricTriangles(sq)) {
      if (!v.allFinite()) continue;
      m.points.push_back(toPoint(v));
    }
    if (!m.points.empty()) out.markers.push_back(m);
  }
  return out;
}

visualization_msgs::MarkerArray gaussianMarkers(const Result& result,
                                                const std::vector<bool>& highlighted,
                                                const std_msgs::Header& header) {
  visualization_msgs::MarkerArray out;
  out.markers.push_back(deleteAll(header));
  const auto& comps = result.current_gmm.components;
  for (std::size_t i = 0; i < comps.size(); ++i) {
    const Gaussian& g = comps[i];
    if (!g.mean.allFinite() || !g.cov.allFinite()) continue;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(0.5 * (g.cov + g.cov.transpose()));
    Eigen::Matrix3d axes = es.eigenvectors();
    if (axes.determinant() < 0) axes.col(2) = -axes.col(2);  // a proper rotation
    const Eigen::Vector3d sigma = es.eigenvalues().cwiseMax(0.0).cwiseSqrt();
    const bool novel = i < highlighted.size() && highlighted[i];
    visualization_msgs::Marker m;
    m.header = header;
    m.ns = novel ? "novel_gaussians" : "gaussians";
    m.id = static_cast<int>(i);
    m.type = visualization_msgs::Marker::SPHERE;
    m.action = visualization_msgs::Marker::ADD;
    m.pose.position = toPoint(g.mean);
    m.pose.orientation = toQuaternion(Eigen::Quaterniond(axes).normalized());
    // 2-sigma radius; a minimum size keeps flat (planar) Gaussians visible.
    m.scale.x = std::max(4.0 * sigma.x(), 1e-3);
    m.scale.y = std::max(4.0 * sigma.y(), 1e-3);
    m.scale.z = std::max(4.0 * sigma.z(), 1e-3);
    if (novel) {
      m.color.r = 1.0f;
      m.color.g = 0.1f;
      m.color.b = 0.1f;
      m.color.a = 0.45f;
    } else {
      m.color.r = m.color.g = m.color.b = 0.6f;
      m.color.a = 0.25f;
    }
    out.markers.push_back(m);
  }
  return out;
}

}  // namespace novelty_detection
