#include "novelty_detection/segmentation/object_completion.h"

#include <algorithm>
#include <map>
#include <utility>

#include "novelty_detection/segmentation/surface_creases.h"

namespace novelty_detection {

void completeObjects(const Cloud& cloud, const Indices& kept, double link_radius_m,
                     double min_share, const std::function<bool(int)>& may_join,
                     std::vector<Indices>* segments, const NearestNeighbourIndex* kept_index,
                     CreaseTest* creases, int min_segment_points) {
  if (!segments || segments->empty() || min_share >= 1.0 || !(link_radius_m > 0) || kept.size() < 2)
    return;
  std::vector<int> owner(cloud.size(), -1);  // segment of each novel point
  std::size_t novel = 0;
  for (std::size_t s = 0; s < segments->size(); ++s)
    for (int i : (*segments)[s]) owner[i] = static_cast<int>(s), ++novel;
  NearestNeighbourIndex own;
  if (!kept_index || kept_index->size() != kept.size()) {
    own.build(cloud, kept);
    kept_index = &own;
  }
  if (kept_index->size() != kept.size()) return;  // a non-finite kept point: no positions
  std::vector<int> nn;
  auto crease = [&](int j) { return creases && creases->nearCrease(j); };
  // An object can only qualify while it has at most novel / min_share points.
  const std::size_t cap = static_cast<std::size_t>(static_cast<double>(novel) / min_share) + 1;
  // Per kept position: the last piece that reached it (crease points, which end a piece
  // without leading on, may belong to the pieces on both sides), and whether it lies in a
  // piece given up as too large to qualify.
  std::vector<int> stamp(kept.size(), -1);
  std::vector<char> large(kept.size(), 0), taken(kept.size(), 0);
  // Per qualifying piece and segment in it: the points it takes (cloud indices), and the
  // segment it came from.
  std::vector<Indices> objects;
  std::vector<int> source, piece_of;
  // Pieces parted by a crease: the crease points each pair reached from both sides.
  std::vector<int> crease_from(kept.size(), -1);
  std::map<std::pair<int, int>, int> contacts;
  std::vector<char> moved(cloud.size(), 0);  // novel points now in an object
  int pieces = 0;
  for (std::size_t k = 0; k < kept.size(); ++k) {
    if (stamp[k] >= 0 || large[k] || owner[kept[k]] < 0 || crease(static_cast<int>(k))) continue;
    // The object (connected piece) through kept[k], breadth first, not crossing creases;
    // given up past `cap` or on reaching a piece given up before.
    const int id = pieces++;
    std::vector<int> piece{static_cast<int>(k)};
    stamp[k] = id;
    bool too_large = false;
    for (std::size_t h = 0; h < piece.size() && !too_large; ++h) {
      if (h > 0 && crease(piece[h])) continue;
      nn.clear();
      kept_index->withinIds(cloud[kept[piece[h]]].getVector3fMap(), link_radius_m, &nn);
      for (int j : nn) {
        if (stamp[j] == id) continue;
        too_large |= large[j] && !crease(j);
        stamp[j] = id;
        piece.push_back(j);
        if (crease(j)) {
          if (crease_from[j] < 0)
            crease_from[j] = id;
          else if (crease_from[j] != id)
            ++contacts[{crease_from[j], id}];
        }
      }
      too_large |= piece.size() > cap;
    }
    if (too_large) {
      for (int j : piece)
        if (!crease(j)) large[j] = 1;
      continue;
    }
    std::size_t in_segments = 0;
    for (int j : piece) in_segments += owner[kept[j]] >= 0 && !moved[kept[j]];
    if (static_cast<int>(piece.size()) < min_segment_points ||
        static_cast<double>(in_segments) < min_share * static_cast<double>(piece.size()))
      continue;
    // A new object: its segments' points in it stay theirs (a segment reaching into two
    // objects parted by a crease is two segments), and its other points that may join take
    // the segment they are nearest to along the object (grown breadth first from all of them
    // at once, through every point of the object).
    std::vector<int> group_of(segments->size(), -1);
    std::vector<int> front, from;
    for (int j : piece) {
      const int i = kept[j];
      if (taken[j] || owner[i] < 0 || moved[i]) continue;
      int& g = group_of[static_cast<std::size_t>(owner[i])];
      if (g < 0) {
        g = static_cast<int>(objects.size());
        objects.emplace_back();
        source.push_back(owner[i]);
        piece_of.push_back(id);
      }
      objects[static_cast<std::size_t>(g)].push_back(i);
      moved[i] = 1;
      taken[j] = 1;
      front.push_back(j);
      from.push_back(g);
    }
    for (std::size_t h = 0; h < front.size(); ++h) {
      nn.clear();
      kept_index->withinIds(cloud[kept[front[h]]].getVector3fMap(), link_radius_m, &nn);
      for (int j : nn) {
        if (stamp[j] != id || taken[j]) continue;
        taken[j] = 1;
        front.push_back(j);
        from.push_back(from[h]);
        if (!may_join || may_join(kept[j]))
          objects[static_cast<std::size_t>(from[h])].push_back(kept[j]);
      }
    }
  }
  if (objects.empty()) return;
  // A segment is split only where a crease parts two of its objects (kMinCreaseContacts
  // crease points reached from both): its other parts (a segment merged across the gaps
  // between tilt lines spans several pieces) and the rest no object took stay with its
  // largest part, as does a part too small to stand alone.
  auto parted = [&](int a, int b) {
    const auto it = contacts.find({std::min(a, b), std::max(a, b)});
    return it != contacts.end() && it->second >= kMinCreaseContacts;
  };
  std::vector<std::vector<std::size_t>> parts(segments->size());
  for (std::size_t o = 0; o < objects.size(); ++o)
    parts[static_cast<std::size_t>(source[o])].push_back(o);
  std::vector<Indices> out;
  for (std::size_t s = 0; s < segments->size(); ++s) {
    std::vector<std::size_t>& mine = parts[s];
    Indices main;
    for (int i : (*segments)[s])
      if (!moved[i]) main.push_back(i);
    std::stable_sort(mine.begin(), mine.end(), [&](std::size_t a, std::size_t b) {
      return objects[a].size() > objects[b].size();
    });
    std::vector<char> alone(mine.size(), 0);
    for (std::size_t a = 0; a < mine.size(); ++a)
      for (std::size_t b = 0; b < mine.size() && !alone[a]; ++b)
        alone[a] = b != a && parted(piece_of[mine[a]], piece_of[mine[b]]) &&
                   static_cast<int>(objects[mine[a]].size()) >= min_segment_points;
    // The largest part that stands alone keeps the rest; with none, the largest part does.
    std::size_t keeper = 0;
    while (keeper < mine.size() && !alone[keeper]) ++keeper;
    if (keeper == mine.size()) keeper = 0;
    for (std::size_t a = 0; a < mine.size(); ++a) {
      Indices& part = objects[mine[a]];
      if (a != keeper && alone[a]) {
        out.push_back(std::move(part));
      } else {
        main.insert(main.end(), part.begin(), part.end());
      }
    }
    if (!main.empty()) out.push_back(std::move(main));
  }
  for (Indices& g : out) std::sort(g.begin(), g.end());
  std::stable_sort(out.begin(), out.end(),
                   [](const Indices& a, const Indices& b) { return a.size() > b.size(); });
  *segments = std::move(out);
}

}  // namespace novelty_detection
