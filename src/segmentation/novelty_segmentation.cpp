#include "novelty_detection/segmentation/novelty_segmentation.h"

#include "common/disjoint_sets.h"
#include "common/knn.h"
#include "novelty_detection/segmentation/depth_jumps.h"
#include "novelty_detection/segmentation/scan_lines.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <tuple>
#include <utility>

namespace novelty_detection {
namespace {

double median(std::vector<double>& v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

}  // namespace

double noveltyDistanceThreshold(std::vector<double> distances, double factor, double floor_m) {
  distances.erase(std::remove_if(distances.begin(), distances.end(),
                                 [](double d) { return !std::isfinite(d); }),
                  distances.end());
  if (distances.empty()) return floor_m;
  std::sort(distances.begin(), distances.end());
  // median + factor * 1.4826 MAD of the distances up to `limit` (sorted input).
  auto threshold = [&](std::size_t count) {
    std::vector<double> part(distances.begin(), distances.begin() + count);
    const double med = part[part.size() / 2];
    for (double& d : part) d = std::abs(d - med);
    std::nth_element(part.begin(), part.begin() + part.size() / 2, part.end());
    return med + factor * 1.4826 * part[part.size() / 2];
  };
  // Estimated on the part of the scene that matches, whatever share of it changed: start
  // from the closer half of the points, then re-estimate on the points within the
  // threshold until it no longer moves (a trimmed fixed point; the changed points, farther
  // than the threshold, never enter it).
  std::size_t count = std::max<std::size_t>(1, (distances.size() + 1) / 2);
  double tau = threshold(count);
  for (int it = 0; it < 50; ++it) {
    const std::size_t next = std::max<std::size_t>(
        1, std::upper_bound(distances.begin(), distances.end(), tau) - distances.begin());
    if (next == count) break;
    count = next;
    tau = threshold(count);
  }
  return std::max(floor_m, tau);
}

std::vector<Indices> linkComponents(const Cloud& cloud, const Indices& indices, double link_factor,
                                    int min_points, double* link_radius_m, double max_spacing_m) {
  std::vector<Indices> out;
  if (link_radius_m) *link_radius_m = 0.0;
  if (indices.empty()) return out;
  Indices finite;  // the index skips non-finite points: they join no component
  finite.reserve(indices.size());
  for (int i : indices) {
    if (cloud[i].getVector3fMap().allFinite()) finite.push_back(i);
  }
  NearestNeighbourIndex tree;
  tree.build(cloud, finite);
  const int n = static_cast<int>(finite.size());
  // Spacing: median distance to the 4th nearest neighbour among the kept points (a sample).
  const int k = std::min(5, n);
  std::vector<double> spacing;
  const int stride = std::max(1, n / 2000);
  for (int i = 0; i < n && k > 1; i += stride) {
    const double d = tree.kthDistance(tree.point(i), k);
    if (std::isfinite(d)) spacing.push_back(d);
  }
  const double radius =
      link_factor * std::min(spacing.empty() ? 0.0 : median(spacing), max_spacing_m);
  if (link_radius_m) *link_radius_m = radius;
  std::vector<int> comp(n, -1);
  int count = 0;
  std::vector<int> stack, nn;
  for (int seed = 0; seed < n; ++seed) {
    if (comp[seed] >= 0) continue;
    Indices members;
    comp[seed] = count;
    stack.assign(1, seed);
    while (!stack.empty()) {
      const int a = stack.back();
      stack.pop_back();
      members.push_back(finite[a]);
      nn.clear();
      if (radius > 0) tree.withinIds(tree.point(a), radius, &nn);
      for (int b : nn) {
        if (comp[b] < 0) {
          comp[b] = count;
          stack.push_back(b);
        }
      }
    }
    ++count;
    if (static_cast<int>(members.size()) >= min_points) {
      std::sort(members.begin(), members.end());
      out.push_back(std::move(members));
    }
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const Indices& a, const Indices& b) { return a.size() > b.size(); });
  return out;
}

double sweepSpacing(const Cloud& cloud, const Indices& sweep, const Indices& points) {
  if (sweep.size() < 5 || points.empty()) return std::numeric_limits<double>::infinity();
  NearestNeighbourIndex index;
  index.build(cloud, sweep);
  return sweepSpacing(cloud, index, points);
}

double sweepSpacing(const Cloud& cloud, const NearestNeighbourIndex& sweep, const Indices& points,
                    std::size_t max_samples) {
  constexpr int k = 5;  // the point itself (it is in the sweep) and its 4 nearest
  if (sweep.size() < k || points.empty()) return std::numeric_limits<double>::infinity();
  std::vector<double> spacing;
  const std::size_t stride =
      std::max<std::size_t>(1, points.size() / std::max<std::size_t>(1, max_samples));
  for (std::size_t j = 0; j < points.size(); j += stride) {
    const double d = sweep.kthDistance(cloud[points[j]].getVector3fMap(), k);
    if (std::isfinite(d)) spacing.push_back(d);
  }
  return spacing.empty() ? std::numeric_limits<double>::infinity() : median(spacing);
}

std::vector<Indices> segmentNovelPoints(const Cloud& cloud, const Indices& points,
                                        const std::vector<int>& owner, int num_gaussians,
                                        const SegmentationParams& params, double* link_radius_m,
                                        const SweepContext& sweep) {
  double link_radius = 0.0;
  const double spacing = !sweep.kept        ? std::numeric_limits<double>::infinity()
                         : sweep.kept_index ? sweepSpacing(cloud, *sweep.kept_index, points)
                                            : sweepSpacing(cloud, *sweep.kept, points);
  const std::vector<Indices> pieces =
      linkComponents(cloud, points, params.link_factor, 1, &link_radius, spacing);
  if (link_radius_m) *link_radius_m = link_radius;
  const std::size_t np = pieces.size();
  std::vector<int> dominant(np);
  std::vector<Eigen::Vector3f> lo(np), hi(np);
  for (std::size_t a = 0; a < np; ++a) {
    std::vector<int> votes(static_cast<std::size_t>(std::max(0, num_gaussians)), 0);
    lo[a].setConstant(std::numeric_limits<float>::infinity());
    hi[a] = -lo[a];
    for (int i : pieces[a]) {
      const auto it = std::lower_bound(points.begin(), points.end(), i);
      ++votes[owner[it - points.begin()]];
      lo[a] = lo[a].cwiseMin(cloud[i].getVector3fMap());
      hi[a] = hi[a].cwiseMax(cloud[i].getVector3fMap());
    }
    dominant[a] = static_cast<int>(std::max_element(votes.begin(), votes.end()) - votes.begin());
  }
  detail::DisjointSets sets(np);
  const auto find = [&sets](int a) { return sets.find(a); };
  std::vector<char> novel_mask;
  const bool can_look = sweep.kept && sweep.origin_known;
  if (can_look) {
    novel_mask.assign(cloud.size(), 0);
    for (int i : points) novel_mask[i] = 1;
  }
  // The box between two pieces' bounding boxes: per axis their gap, or their overlap.
  auto gapBox = [&](std::size_t a, std::size_t b) {
    const Eigen::Vector3f inner_lo = hi[a].cwiseMin(hi[b]), inner_hi = lo[a].cwiseMax(lo[b]);
    return Eigen::AlignedBox3f(inner_lo.cwiseMin(inner_hi), inner_lo.cwiseMax(inner_hi));
  };
  // Stacked pieces: whether the sweep's beams ended in or passed through the gap.
  auto seenThrough = [&](std::size_t a, std::size_t b) {
    const Eigen::AlignedBox3f box = gapBox(a, b);
    return beamsThroughBox(cloud, *sweep.kept, novel_mask, sweep.origin, box.min(), box.max(),
                           kSeenGapBeams) >= kSeenGapBeams;
  };
  // Pieces side by side: whether the sweep's beams passed between them, to whatever lies
  // beyond (the floor too).
  auto seenPast = [&](std::size_t a, std::size_t b) {
    const Eigen::AlignedBox3f box = gapBox(a, b);
    return beamsPastBox(cloud, novel_mask, sweep.origin, box.min(), box.max(), kSeenGapBeams) >=
           kSeenGapBeams;
  };
  // Whether kSeenGapBeams or more returns lie in front of the gap between two pieces (their
  // beams aimed into it), their own points aside (flagged in `own` for the count, then
  // cleared: one mask for every pair asked).
  std::vector<char> own;
  auto hiddenGap = [&](std::size_t a, std::size_t b) {
    if (own.empty()) own.assign(cloud.size(), 0);
    const auto flag = [&](char value) {
      for (const std::size_t c : {a, b})
        for (int i : pieces[c]) own[static_cast<std::size_t>(i)] = value;
    };
    flag(1);
    const Eigen::AlignedBox3f box = gapBox(a, b);
    const bool hidden = beamsBeforeBox(cloud, own, sweep.origin, box.min(), box.max(),
                                       kSeenGapBeams) >= kSeenGapBeams;
    flag(0);
    return hidden;
  };
  // Stacked pieces: whether, seen from the sweep's origin, one lies wholly above the other
  // (pieces one behind the other overlap in elevation) by at most kLineGapSteps of the
  // sweep's steps between scan lines at their bearing.
  std::optional<ScanLineSpacing> lines;  // measured when first needed
  std::vector<Eigen::Vector2f> elevations;
  const auto lineGap = [&](std::size_t a, std::size_t b) {
    if (!lines) {
      lines.emplace(cloud, sweep.origin);
      elevations.resize(np);
      for (std::size_t c = 0; c < np; ++c) {
        Eigen::Vector2f& e = elevations[c];
        e << std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity();
        for (int i : pieces[c]) {
          const float el = static_cast<float>(
              ScanLineSpacing::elevationOf(cloud[i].getVector3fMap(), sweep.origin));
          e = Eigen::Vector2f(std::min(e.x(), el), std::max(e.y(), el));
        }
      }
    }
    const std::size_t below = hi[a].z() < lo[b].z() ? a : b, above = below == a ? b : a;
    const Eigen::AlignedBox3f box = gapBox(a, b);
    const double step = lines->stepAt(ScanLineSpacing::azimuthOf(box.center(), sweep.origin));
    const double apart = elevations[above].x() - elevations[below].y();
    return step > 0.0 && apart > 0.0 && apart <= kLineGapSteps * step;
  };
  // Only pieces that could each stand as a segment can be two objects.
  const std::size_t least = static_cast<std::size_t>(std::max(1, params.min_segment_points));
  const float gap = static_cast<float>(params.merge_gap_factor * link_radius);
  const float floor_gap = static_cast<float>(params.merge_floor_gap_factor * link_radius);
  // Stacked pieces merge first; pieces side by side then merge nearest first, unless that
  // would join two groups, each large enough to be a segment, seen one in front of the other;
  // those of different Gaussians across a hidden gap last (first in each entry: 1), and
  // only groups that each stand as a segment: one object's two sides, not a fragment taken
  // into whatever segment lies across a shadow.
  std::vector<std::tuple<int, float, int, int>> side_by_side;
  for (std::size_t a = 0; a < np; ++a) {
    for (std::size_t b = a + 1; b < np; ++b) {
      const Eigen::Vector3f sep =
          (lo[b] - hi[a]).cwiseMax(lo[a] - hi[b]).cwiseMax(Eigen::Vector3f::Zero());
      if (sep.norm() > gap) {
        // Farther apart than the link radius allows: one object still when one piece stands
        // above the other (footprints within the floor gap) across no more than a gap
        // between scan lines that the sweep did not see through (at low range noise the
        // link radius is the spacing along a line).
        if (sep.z() > 0.f && sep.head<2>().norm() <= floor_gap && can_look && lineGap(a, b) &&
            !seenThrough(a, b))
          sets.unite(static_cast<int>(a), static_cast<int>(b));
        continue;
      }
      // Same Gaussian, footprints close: one object seen through the gaps between lines,
      // unless the pieces stand side by side, each large enough to be a segment, and the
      // sweep's beams passed between them (two objects a hand apart, one Gaussian over both).
      // Any Gaussians, footprints overlapping, one piece above the other: one object cut by a
      // gap between two tilt lines (a person's trunk and legs), unless the sweep saw through
      // that gap. Objects side by side share heights, so this never joins them.
      const bool two_objects =
          !sep.head<2>().isZero() && pieces[a].size() >= least && pieces[b].size() >= least;
      const bool same = dominant[a] == dominant[b] && sep.head<2>().norm() <= floor_gap &&
                        (!two_objects || !can_look || !seenPast(a, b));
      const bool stacked =
          sep.head<2>().isZero() && sep.z() > 0.f && (same || !can_look || !seenThrough(a, b));
      // Pieces of different Gaussians side by side whose gap the sweep did not see: the
      // beams toward it ended in front of it (an object standing before them hid it), none
      // passed through it. Pieces of one object on both sides of a nearer one's shadow.
      const bool hidden = !stacked && !same && can_look && !sep.head<2>().isZero() &&
                          sep.head<2>().norm() <= floor_gap && !seenPast(a, b) &&
                          !seenThrough(a, b) && hiddenGap(a, b);
      if (stacked)
        sets.unite(static_cast<int>(a), static_cast<int>(b));
      else if (same || hidden)
        side_by_side.emplace_back(same ? 0 : 1, sep.norm(), static_cast<int>(a),
                                  static_cast<int>(b));
    }
  }
  if (!side_by_side.empty()) {
    std::sort(side_by_side.begin(), side_by_side.end());
    // Two objects on the same tilt lines, the nearer hiding part of the other, meet at depth
    // jumps larger than the footprint gap one object's pieces may show, the farther seen at
    // heights the nearer also covers, and their footprints apart. A box's top seen past its
    // front edge is as high as that edge; its side seen past a corner, or a person's arm past
    // the trunk, stands on or beside its footprint.
    std::optional<std::vector<DepthJump>> jumps;  // found when first needed
    std::vector<std::size_t> size(np);
    std::vector<float> top(np, -std::numeric_limits<float>::infinity());
    for (std::size_t a = 0; a < np; ++a) {
      const int r = find(static_cast<int>(a));
      size[r] += pieces[a].size();
      top[r] = std::max(top[r], hi[a].z());
    }
    // The points of group rb seen behind group ra's, below ra's top less a link radius.
    const auto behind = [&](int ra, int rb) {
      std::vector<int> far;
      for (const DepthJump& j : *jumps)
        if (find(j.near) == ra && find(j.far) == rb &&
            cloud[j.far_point].z < top[ra] - static_cast<float>(link_radius))
          far.push_back(j.far_point);
      std::sort(far.begin(), far.end());
      return static_cast<std::size_t>(std::unique(far.begin(), far.end()) - far.begin());
    };
    // Whether no point of group rb stands within kInFrontApartLinks link radii of group ra's
    // on the floor plan.
    const double apart = kInFrontApartLinks * link_radius;
    const auto footprintsApart = [&](int ra, int rb) {
      std::vector<Eigen::Vector3f> plan;
      for (std::size_t a = 0; a < np; ++a)
        if (find(static_cast<int>(a)) == ra)
          for (int i : pieces[a]) plan.emplace_back(cloud[i].x, cloud[i].y, 0.f);
      const detail::KnnTree tree(plan);
      for (std::size_t b = 0; b < np; ++b)
        if (find(static_cast<int>(b)) == rb)
          for (int i : pieces[b])
            if (tree.anyWithin(Eigen::Vector3f(cloud[i].x, cloud[i].y, 0.f), apart)) return false;
      return true;
    };
    const auto inFront = [&](int ra, int rb) {
      if (!can_look || size[ra] < least || size[rb] < least) return false;
      if (!jumps) {  // among the pieces of the groups side-by-side merges may join
        std::vector<char> involved(np, 0);
        for (const auto& [across, sep, a, b] : side_by_side)
          involved[find(a)] = involved[find(b)] = 1;
        for (std::size_t a = 0; a < np; ++a) involved[a] = involved[find(static_cast<int>(a))];
        jumps = depthJumps(cloud, pieces, sweep.origin, link_radius, floor_gap, involved);
      }
      return behind(ra, rb) + behind(rb, ra) >= kSeenGapBeams && footprintsApart(ra, rb);
    };
    for (const auto& [across, sep, a, b] : side_by_side) {
      const int ra = find(a), rb = find(b);
      if (ra == rb) continue;
      if (across && (size[ra] < least || size[rb] < least)) continue;
      if (inFront(ra, rb)) continue;
      sets.unite(ra, rb);
      const int r = find(ra);
      size[r] = size[ra] + size[rb];
      top[r] = std::max(top[ra], top[rb]);
    }
  }
  std::vector<Indices> merged(np);
  for (std::size_t a = 0; a < np; ++a) {
    Indices& m = merged[find(static_cast<int>(a))];
    m.insert(m.end(), pieces[a].begin(), pieces[a].end());
  }
  std::vector<Indices> comps;
  for (Indices& c : merged) {
    if (c.empty() || static_cast<int>(c.size()) < params.min_segment_points) continue;
    std::sort(c.begin(), c.end());
    comps.push_back(std::move(c));
  }
  std::stable_sort(comps.begin(), comps.end(),
                   [](const Indices& a, const Indices& b) { return a.size() > b.size(); });
  return comps;
}

void labelDuplicates(const Indices& duplicates, const Indices& duplicate_of,
                     std::vector<int>& labels, std::vector<Segment>& segments) {
  bool any = false;
  for (std::size_t k = 0; k < duplicates.size(); ++k) {
    const int id = labels.at(duplicate_of[k]);
    labels.at(duplicates[k]) = id;
    if (id <= 0) continue;
    for (Segment& seg : segments) {
      if (seg.id == id) seg.indices.push_back(duplicates[k]), any = true;
    }
  }
  if (any)
    for (Segment& seg : segments) std::sort(seg.indices.begin(), seg.indices.end());
}

}  // namespace novelty_detection
