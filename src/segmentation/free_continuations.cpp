// Continuations of novel segments into free space (segmentation/free_continuations.h).
#include "novelty_detection/segmentation/free_continuations.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <deque>

namespace novelty_detection {

std::size_t growIntoFreeSpace(const Cloud& cloud, const Indices& kept,
                              const NearestNeighbourIndex& kept_index,
                              std::vector<Indices>* segments, double link_radius_m,
                              double max_growth, const std::function<bool(int)>& changed) {
  if (!segments || segments->empty() || kept.empty() || !(link_radius_m > 0.0) ||
      !std::isfinite(link_radius_m) || !(max_growth > 0.0))
    return 0;
  // Per kept position: 0 not asked, 1 taken (by a segment or the growth), 2 asked, unchanged.
  std::vector<std::uint8_t> state(kept.size(), 0);
  for (const Indices& s : *segments)
    for (int i : s) {
      const auto it = std::lower_bound(kept.begin(), kept.end(), i);
      if (it != kept.end() && *it == i) state[static_cast<std::size_t>(it - kept.begin())] = 1;
    }
  std::size_t total = 0;
  std::vector<int> ids;
  std::vector<std::pair<float, int>> near;
  for (Indices& seg : *segments) {
    const std::size_t cap = static_cast<std::size_t>(max_growth * static_cast<double>(seg.size()));
    std::deque<int> frontier(seg.begin(), seg.end());  // input indices
    Indices added;
    while (!frontier.empty() && added.size() < cap) {
      const Eigen::Vector3f p = cloud[frontier.front()].getVector3fMap();
      frontier.pop_front();
      ids.clear();
      kept_index.withinIds(p, link_radius_m, &ids);
      near.clear();
      for (int id : ids)
        if (state[static_cast<std::size_t>(id)] == 0)
          near.emplace_back((kept_index.point(id) - p).squaredNorm(), id);
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
