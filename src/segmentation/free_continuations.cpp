// Continuations of novel segments into free space (segmentation/free_continuations.h).
#include "novelty_detection/segmentation/free_continuations.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <deque>
#include <utility>

#include <Eigen/Geometry>

#include "novelty_detection/point_grid.h"

namespace novelty_detection {

std::vector<double> ownSpacingRadii(const Cloud& cloud, const std::vector<Indices>& segments,
                                    const NearestNeighbourIndex& kept_index, double link_factor,
                                    double link_radius_m, double max_radius_m) {
  std::vector<double> radii(segments.size(), link_radius_m);
  for (std::size_t s = 0; s < segments.size(); ++s) {
    const double spacing = sweepSpacing(cloud, kept_index, segments[s], kSpacingSamples);
    if (std::isfinite(spacing))
      radii[s] =
          std::clamp(link_factor * spacing, link_radius_m, std::max(link_radius_m, max_radius_m));
  }
  return radii;
}

std::size_t growIntoFreeSpace(const Cloud& cloud, const Indices& kept,
                              const NearestNeighbourIndex& kept_index,
                              std::vector<Indices>* segments, double link_radius_m,
                              double max_growth, const std::function<bool(int)>& changed,
                              const std::vector<double>* radii) {
  if (!segments || segments->empty() || kept.empty() || !(max_growth > 0.0)) return 0;
  if (radii && radii->size() != segments->size()) return 0;
  // Each segment's link radius; the largest bounds every search.
  const std::vector<double> uniform(radii ? 0 : segments->size(), link_radius_m);
  const std::vector<double>& radius = radii ? *radii : uniform;
  for (double r : radius)
    if (!(r > 0.0) || !std::isfinite(r)) return 0;
  const double largest = *std::max_element(radius.begin(), radius.end());
  // Per kept position: 0 not asked, 1 taken (by a segment or the growth), 2 asked, unchanged.
  std::vector<std::uint8_t> state(kept.size(), 0);
  for (const Indices& s : *segments)
    for (int i : s) {
      const auto it = std::lower_bound(kept.begin(), kept.end(), i);
      if (it != kept.end() && *it == i) state[static_cast<std::size_t>(it - kept.begin())] = 1;
    }
  // The points in no segment within the link radius of a segment's box: the only ones a
  // segment's own points link to, in a hash grid (most of a large segment's points have none
  // about them). The points a segment gains are searched in the index: their links may leave
  // the boxes. Both keep the index's test (squared float distance below the radius's), so
  // either search finds the same points.
  std::vector<Eigen::AlignedBox3f> boxes;
  for (std::size_t s = 0; s < segments->size(); ++s) {
    Eigen::AlignedBox3f box;
    for (int i : (*segments)[s]) box.extend(cloud[i].getVector3fMap());
    const auto pad = Eigen::Vector3f::Constant(static_cast<float>(radius[s]));
    if (!box.isEmpty()) boxes.emplace_back(box.min() - pad, box.max() + pad);
  }
  std::vector<int> near_ids;  // kept positions
  Points3d near_points;
  for (std::size_t k = 0; k < kept.size(); ++k) {
    if (state[k] != 0) continue;
    const Eigen::Vector3f p = cloud[kept[k]].getVector3fMap();
    for (const Eigen::AlignedBox3f& box : boxes)
      if (box.contains(p)) {
        near_ids.push_back(static_cast<int>(k));
        near_points.push_back(p.cast<double>());
        break;
      }
  }
  if (near_ids.empty()) return 0;
  const PointGrid grid(near_points, largest * (1.0 + 1e-6));
  std::size_t total = 0;
  std::vector<int> ids;
  std::vector<std::pair<float, int>> near;
  float r2 = 0.f;
  const auto consider = [&](int id, const Eigen::Vector3f& p) {
    if (state[static_cast<std::size_t>(id)] != 0) return;
    const float d2 = (kept_index.point(id) - p).squaredNorm();
    if (d2 < r2) near.emplace_back(d2, id);
  };
  for (std::size_t s = 0; s < segments->size(); ++s) {
    Indices& seg = (*segments)[s];
    r2 = static_cast<float>(radius[s] * radius[s]);
    const double reach = radius[s] * (1.0 + 1e-6);  // a superset of the float test's points
    const std::size_t cap = static_cast<std::size_t>(max_growth * static_cast<double>(seg.size()));
    std::deque<int> frontier(seg.begin(), seg.end());  // input indices
    std::size_t own = seg.size();                      // the first `own` are the segment's
    Indices added;
    while (!frontier.empty() && added.size() < cap) {
      const Eigen::Vector3f p = cloud[frontier.front()].getVector3fMap();
      frontier.pop_front();
      near.clear();
      if (own > 0) {
        --own;
        grid.forNeighbours(p.cast<double>(), reach,
                           [&](int j) { consider(near_ids[static_cast<std::size_t>(j)], p); });
      } else {
        ids.clear();
        kept_index.withinIds(p, radius[s], &ids);
        for (int id : ids) consider(id, p);
      }
      std::sort(near.begin(), near.end());
      for (const auto& [d2, id] : near) {
        if (added.size() >= cap) break;
        std::uint8_t& st = state[static_cast<std::size_t>(id)];
        if (st != 0) continue;
        const int index = kept[static_cast<std::size_t>(id)];
        st = changed(index) ? 1 : 2;
        if (st != 1) continue;
        added.push_back(index);
        frontier.push_back(index);
      }
    }
    if (added.empty()) continue;
    total += added.size();
    seg.insert(seg.end(), added.begin(), added.end());
    std::sort(seg.begin(), seg.end());
  }
  return total;
}

}  // namespace novelty_detection
