#include "novelty_detection/ros/operator_display.h"

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "novelty_detection/ros/result_messages.h"

namespace novelty_detection {
namespace {

// Letter height: a quarter of the change's largest extent, within [5 cm, 18 cm], so that a
// tabletop object's label does not hide the table and a room's stays readable.
constexpr double kMinTextHeightM = 0.05, kMaxTextHeightM = 0.18;

std_msgs::ColorRGBA disappearedColour(float alpha) {
  std_msgs::ColorRGBA c;
  c.r = 0.75f;
  c.g = 0.1f;
  c.b = 0.15f;
  c.a = alpha;
  return c;
}

// Text in a light tint of the segment's colour: readable on rviz's dark background.
std_msgs::ColorRGBA textColour(int segment) {
  std_msgs::ColorRGBA c = segmentColour(segment, 1.0f);
  c.r = 0.5f * (c.r + 1.0f);
  c.g = 0.5f * (c.g + 1.0f);
  c.b = 0.5f * (c.b + 1.0f);
  return c;
}

visualization_msgs::Marker baseMarker(const std_msgs::Header& header, const char* ns, int id,
                                      int type) {
  visualization_msgs::Marker m;
  m.header = header;
  m.ns = ns;
  m.id = id;
  m.type = type;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1.0;
  return m;
}

visualization_msgs::Marker textMarker(const Novelty& n, bool disappeared, const Eigen::Vector3d& up,
                                      const std_msgs::Header& header, int id) {
  visualization_msgs::Marker m =
      baseMarker(header, disappeared ? "disappeared_text" : "novelty_text", id,
                 visualization_msgs::Marker::TEXT_VIEW_FACING);
  const Eigen::Vector3d lo(n.bbox_min.x, n.bbox_min.y, n.bbox_min.z);
  const Eigen::Vector3d hi(n.bbox_max.x, n.bbox_max.y, n.bbox_max.z);
  m.scale.z = std::clamp(0.25 * (hi - lo).maxCoeff(), kMinTextHeightM, kMaxTextHeightM);
  // One letter height above the box along up (its half extent along up: the box's support
  // in that direction); a disappearance's below it, so that a new object standing where an
  // old one stood keeps both labels readable.
  const double half = 0.5 * (hi - lo).cwiseAbs().dot(up.cwiseAbs());
  const Eigen::Vector3d at = 0.5 * (lo + hi) + (disappeared ? -1.0 : 1.0) * (half + m.scale.z) * up;
  m.pose.position.x = at.x();
  m.pose.position.y = at.y();
  m.pose.position.z = at.z();
  m.color = disappeared ? disappearedColour(1.0f) : textColour(n.id);
  m.text = noveltyLabel(n, disappeared);
  return m;
}

geometry_msgs::Point corner(const Novelty& n, int bits) {
  geometry_msgs::Point p;
  p.x = (bits & 1) ? n.bbox_max.x : n.bbox_min.x;
  p.y = (bits & 2) ? n.bbox_max.y : n.bbox_min.y;
  p.z = (bits & 4) ? n.bbox_max.z : n.bbox_min.z;
  return p;
}

visualization_msgs::Marker boxOutline(const Novelty& n, const std_msgs::Header& header, int id) {
  visualization_msgs::Marker m =
      baseMarker(header, "disappeared_box", id, visualization_msgs::Marker::LINE_LIST);
  m.scale.x = 0.02;  // line width [m]
  m.color = disappearedColour(0.9f);
  // The 12 edges join corners whose bit patterns differ in exactly one bit.
  for (int a = 0; a < 8; ++a)
    for (int bit = 1; bit < 8; bit <<= 1)
      if (!(a & bit)) {
        m.points.push_back(corner(n, a));
        m.points.push_back(corner(n, a | bit));
      }
  return m;
}

bool finiteBox(const Novelty& n) {
  return std::isfinite(n.bbox_min.x) && std::isfinite(n.bbox_min.y) &&
         std::isfinite(n.bbox_min.z) && std::isfinite(n.bbox_max.x) &&
         std::isfinite(n.bbox_max.y) && std::isfinite(n.bbox_max.z);
}

}  // namespace

std::string noveltyLabel(const Novelty& n, bool disappeared) {
  char state[48];
  if (disappeared)
    std::snprintf(state, sizeof(state), "gone");
  else if (n.confirmed)
    std::snprintf(state, sizeof(state), "confirmed (seen %u)", n.times_seen);
  else
    std::snprintf(state, sizeof(state), "new");
  char text[160];
  std::snprintf(text, sizeof(text), "#%d %s: %.2f x %.2f x %.2f m, %u pts", n.id, state,
                n.bbox_max.x - n.bbox_min.x, n.bbox_max.y - n.bbox_min.y,
                n.bbox_max.z - n.bbox_min.z, n.points);
  return text;
}

visualization_msgs::MarkerArray noveltyLabelMarkers(const NoveltyArray& array,
                                                    const Eigen::Vector3d& up) {
  const Eigen::Vector3d u =
      up.allFinite() && up.norm() > 1e-6 ? up.normalized() : Eigen::Vector3d::UnitZ();
  visualization_msgs::MarkerArray out;
  visualization_msgs::Marker clear;
  clear.header = array.header;
  clear.action = visualization_msgs::Marker::DELETEALL;
  out.markers.push_back(clear);
  for (std::size_t i = 0; i < array.novelties.size(); ++i) {
    if (!finiteBox(array.novelties[i])) continue;
    out.markers.push_back(
        textMarker(array.novelties[i], false, u, array.header, static_cast<int>(i)));
  }
  for (std::size_t i = 0; i < array.disappeared.size(); ++i) {
    const Novelty& n = array.disappeared[i];
    if (!finiteBox(n)) continue;
    out.markers.push_back(textMarker(n, true, u, array.header, static_cast<int>(i)));
    out.markers.push_back(boxOutline(n, array.header, static_cast<int>(i)));
  }
  return out;
}

std::vector<bool> gaussiansHoldingNovelPoints(const Result& result, const Cloud& cloud) {
  const auto& comps = result.current_gmm.components;
  std::vector<bool> holding(comps.size(), false);
  if (result.labels.size() != cloud.size() || comps.empty()) return holding;
  // log(weight) - log det(cov) / 2 and the Cholesky factor of each usable component.
  struct Component {
    Eigen::LLT<Eigen::Matrix3d> llt;
    double log_norm = -std::numeric_limits<double>::infinity();
  };
  std::vector<Component> c(comps.size());
  bool any_novel = false;
  for (std::size_t k = 0; k < comps.size(); ++k) {
    const Gaussian& g = comps[k];
    if (!(g.weight > 0.0) || !g.mean.allFinite() || !g.cov.allFinite()) continue;
    c[k].llt.compute(0.5 * (g.cov + g.cov.transpose()));
    if (c[k].llt.info() != Eigen::Success) continue;
    const Eigen::Vector3d diag = c[k].llt.matrixL().toDenseMatrix().diagonal();
    if ((diag.array() <= 0.0).any()) continue;
    c[k].log_norm = std::log(g.weight) - diag.array().log().sum();
    any_novel = any_novel || (k < result.novel_gaussian.size() && result.novel_gaussian[k]);
  }
  if (!any_novel) return holding;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (result.labels[i] <= 0) continue;
    const Eigen::Vector3d p = cloud[i].getVector3fMap().cast<double>();
    if (!p.allFinite()) continue;
    double best = -std::numeric_limits<double>::infinity();
    std::size_t arg = comps.size();
    for (std::size_t k = 0; k < comps.size(); ++k) {
      if (!std::isfinite(c[k].log_norm)) continue;
      const double m = c[k].llt.matrixL().solve(p - comps[k].mean).squaredNorm();
      const double score = c[k].log_norm - 0.5 * m;
      if (score > best) {
        best = score;
        arg = k;
      }
    }
    if (arg < comps.size() && arg < result.novel_gaussian.size() && result.novel_gaussian[arg])
      holding[arg] = true;
  }
  return holding;
}

}  // namespace novelty_detection
