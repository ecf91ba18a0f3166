#include "novelty_detection/preprocess/self_returns.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <mutex>
#include <sstream>
#include <stdexcept>

#include "common/knn.h"
#include "common/parallel.h"
#include "novelty_detection/preprocess/preprocess.h"

namespace novelty_detection {
namespace {

using Points = std::vector<Eigen::Vector3f>;

/// The finite points of a cloud with repeats of one position (clouds stored twice, merged
/// sweeps) set aside: spacings and tolerances are measured between distinct samples, and a
/// repeat takes the mark of its first occurrence (copyToRepeats).
struct Distinct {
  Indices repeats, first;  // declared before `unique`, which fills them
  Indices unique;
  explicit Distinct(const Cloud& cloud)
      : unique(removeDuplicates(cloud, finiteIndices(cloud), &repeats, &first)) {}
  void copyToRepeats(std::vector<std::uint8_t>* mask) const {
    for (std::size_t k = 0; k < repeats.size(); ++k) (*mask)[repeats[k]] = (*mask)[first[k]];
  }
};

/// The distinct points of `cloud` within max_range of its sensor, in the sensor's frame; the
/// ones closer than min_range or inside `body` (sensor frame) are marked in `mask` directly.
Points nearInSensorFrame(const Cloud& cloud, const Indices& distinct, double min_range,
                         double max_range, const Eigen::AlignedBox3f& body, std::vector<int>* index,
                         std::vector<std::uint8_t>* mask) {
  const Eigen::Vector3f o = cloud.sensor_origin_.head<3>();
  const Eigen::Matrix3f Rt = cloud.sensor_orientation_.normalized().toRotationMatrix().transpose();
  Points near;
  mask->assign(cloud.size(), 0);
  for (const int i : distinct) {
    const Eigen::Vector3f d = cloud[i].getVector3fMap() - o;
    const float r = d.norm();
    if (r < min_range) {
      (*mask)[i] = 1;
      continue;
    }
    const Eigen::Vector3f l = Rt * d;
    if (!body.isEmpty() && body.contains(l)) {
      (*mask)[i] = 1;
      continue;
    }
    if (r >= max_range) continue;
    near.push_back(l);
    index->push_back(static_cast<int>(i));
  }
  return near;
}

/// Marks the finite points of `cloud` closer than min_range to its sensor or inside `body`
/// (nearInSensorFrame()'s marks, every point tested on its own: a repeat of a position gets
/// its first occurrence's mark anyway), and counts them.
void markNearOrInBody(const Cloud& cloud, double min_range, const Eigen::AlignedBox3f& body,
                      std::vector<std::uint8_t>* mask, std::size_t* count) {
  mask->assign(cloud.size(), 0);
  *count = 0;
  if (!(min_range > 0.0) && body.isEmpty()) return;  // nothing can be marked
  std::vector<int> unused;
  nearInSensorFrame(cloud, finiteIndices(cloud), min_range, 0.0, body, &unused, mask);
  for (const std::uint8_t m : *mask) *count += m;
}

/// The points of `cloud` at `indices` (map frame).
Points pointsAt(const Cloud& cloud, const Indices& indices) {
  Points out;
  out.reserve(indices.size());
  for (const int i : indices) out.push_back(cloud[i].getVector3fMap());
  return out;
}

/// Neighbours that set a point's own sampling scale: the distance to the k-th nearest point of
/// its own sweep (sensor frame) is the spacing of the beams that hit the surface around it,
/// whatever the sensor's resolution, the surface's range and slant, or a sub-sampling did.
constexpr int kSpacingNeighbours = 16;

/// How many of a point's own sampling spacings (kSpacingNeighbours) its match in the other
/// sweep may lie away: two samplings of one surface by other beams are that far apart where
/// the surface is sampled sparsely (a slanted part of the robot, a sub-sampled cloud).
constexpr double kSpacingFactor = 3.0;

/// How much better the robot's frame must explain such a point than the map does.
constexpr double kFrameRatio = 2.0;

/// Marks the points of `a` (sensor frame, indexed by `own`; a_index into `cloud`) that the
/// robot's frame explains and the map does not, with d_s the distance to the nearest point of
/// `b` (the other sweep's sensor frame) and d_m the distance to the nearest point of the other
/// sweep (map frame; within(p, r) says whether d_m <= r):
///  - d_s <= tol < d_m: within the common tolerance of the robot's frame, not of the map's;
///  - or d_s <= kSpacingFactor * (the point's own sampling spacing) and d_m beyond both the
///    novelty distance and kFrameRatio * d_s: a sparsely sampled part of the robot, seen on
///    other beams in the two sweeps, that the map cannot explain (it would be a novelty).
/// Points the map explains within the novelty distance are left to the first rule alone, so
/// static surfaces keep their share in the sweep.
template <class MapWithin>
void markMatches(const Points& a, const std::vector<int>& a_index, const detail::KnnTree& own,
                 const detail::KnnTree& b, double tol, double novelty_distance, const Cloud& cloud,
                 const MapWithin& within, int threads, std::vector<std::uint8_t>* mask) {
  // The point's own sampling spacing: its k-th nearest point other than itself (k clamped to
  // the points there are), i.e. the (k+1)-th nearest with itself counted.
  const int k = std::min<int>(kSpacingNeighbours, static_cast<int>(own.size()) - 1) + 1;
  // Blocks of points on `threads` threads: each point writes only its own (distinct) slot.
  // The points go in the order of their own index: neighbours one after another, whose
  // searches in the map and in the other sweep follow the same paths.
  constexpr int kBlock = 1024;
  const int n = static_cast<int>(a.size());
  const std::vector<int>& order = own.treeOrder();
  detail::parallelForBlocks(n, kBlock, threads, [&](int t) {
    const int i = order[static_cast<std::size_t>(t)];
    // Cheapest test first: a point the map explains within both distances fits neither rule
    // (most of a sweep), whatever the robot's frame says.
    const Eigen::Vector3f p = cloud[a_index[i]].getVector3fMap();
    if (within(p, std::min(tol, novelty_distance))) return;
    if (within(p, novelty_distance)) {
      // Then tol < novelty_distance (else the test above held), d_m > tol, and the second
      // rule cannot hold (its bound is at least the novelty distance): the first holds
      // when ds <= tol, all that is needed of ds.
      if (b.anyWithin(a[i], tol)) (*mask)[a_index[i]] = 1;
      return;
    }
    const double ds = b.nearestDistance(a[i]);
    const bool sparse = !within(p, std::max(novelty_distance, kFrameRatio * ds));
    if (!(ds <= tol)) {
      // Only the second rule can hold; the map test first (it settles most points), then
      // ds <= kSpacingFactor * (k-th nearest distance) unless k points lie closer than that.
      if (sparse && !own.atLeast(a[i], k, [ds](float d2) {
            return kSpacingFactor * std::sqrt(static_cast<double>(d2)) < ds;
          }))
        (*mask)[a_index[i]] = 1;
      return;
    }
    if (sparse || !within(p, tol)) (*mask)[a_index[i]] = 1;
  });
}

/// How far apart, in match tolerances, two points of one surface may lie and be linked when a
/// group of matches is followed along the novel structure it belongs to (releaseReachingOut).
constexpr double kLinkTolerances = 2.0;

/// Releases the marks of matches that are part of novel structure reaching out of the
/// robot's range. The robot lies within max_range of its sensor. A changed surface near the
/// sensor that, in the sensor's frame, happens to lie where the other sweep had a surface (a
/// door leaf swung by about the robot's own turn and step) is matched along the strip where
/// the two coincide, and runs on as novel structure past it. Each group of marked points of
/// `a` (sensor frame, own tree `own`, a_index into `cloud`) that the map does not explain
/// within the novelty distance, followed through the near points the map does not explain
/// either (linked within `link`), that reaches the rim of the range (within `link` of
/// max_range) at a point left unmarked is no part of the robot: its marks go, when it holds
/// at least `min_matched` marked points (fewer are no strip of a surface to tell from a part
/// of the robot the match missed in part).
template <class MapWithin>
void releaseReachingOut(const Points& a, const std::vector<int>& a_index,
                        const detail::KnnTree& own, double novelty_distance, double link,
                        double max_range, int min_matched, const Cloud& cloud,
                        const MapWithin& within, std::vector<std::uint8_t>* mask) {
  const int n = static_cast<int>(a.size());
  std::vector<std::int8_t> novel(static_cast<std::size_t>(n), -1);  // -1: not asked yet
  const auto isNovel = [&](int i) {
    std::int8_t& v = novel[static_cast<std::size_t>(i)];
    if (v < 0) v = within(cloud[a_index[i]].getVector3fMap(), novelty_distance) ? 0 : 1;
    return v == 1;
  };
  const auto marked = [&](int i) { return (*mask)[a_index[i]] != 0; };
  std::vector<char> seen(static_cast<std::size_t>(n), 0);
  std::vector<int> group, around;
  const double rim = max_range - link;
  for (int i = 0; i < n; ++i) {
    if (seen[i] || !marked(i) || !isNovel(i)) continue;
    group.assign(1, i);
    seen[i] = 1;
    bool reaches = false;
    int matched = 0;
    for (std::size_t g = 0; g < group.size(); ++g) {
      const Eigen::Vector3f& p = a[group[g]];
      if (marked(group[g]))
        ++matched;
      else if (p.norm() >= rim)
        reaches = true;
      around.clear();
      own.within(p, link, &around);
      for (const int j : around) {
        if (seen[j] || !isNovel(j)) continue;
        seen[j] = 1;
        group.push_back(j);
      }
    }
    if (reaches && matched >= min_matched)
      for (const int j : group) (*mask)[a_index[j]] = 0;
  }
}

}  // namespace

Eigen::AlignedBox3f parseBodyBox(const std::string& text) {
  Eigen::AlignedBox3f box;  // empty
  if (text.find_first_not_of(" \t") == std::string::npos) return box;
  std::istringstream in(text);
  Eigen::Vector3f lo, hi;
  std::string rest;
  if (!(in >> lo.x() >> lo.y() >> lo.z() >> hi.x() >> hi.y() >> hi.z()) || (in >> rest) ||
      !lo.allFinite() || !hi.allFinite() || (lo.array() > hi.array()).any()) {
    throw std::invalid_argument("parameter preprocess/body_box = '" + text +
                                "' must be empty or six numbers 'xmin ymin zmin xmax ymax zmax' "
                                "with each min <= max [m]");
  }
  return Eigen::AlignedBox3f(lo, hi);
}

double headingChange(const Eigen::Quaternionf& from, const Eigen::Quaternionf& to) {
  // The twist about z of the rotation from `from` to `to` (swing-twist decomposition).
  const Eigen::Quaternionf rel = to.normalized() * from.normalized().conjugate();
  const double twist = 2.0 * std::atan2(static_cast<double>(rel.z()), static_cast<double>(rel.w()));
  return std::abs(std::remainder(twist, 2.0 * M_PI));
}

/// The reference's side: what depends on the map and the parameters alone.
struct SelfReturnReference::Impl {
  double max_range, min_range;
  std::string body_box;
  Distinct rd;
  std::vector<int> ri;             ///< reference index of each near point
  std::vector<std::uint8_t> mask;  ///< min_range_m and body_box marks, per reference point
  Points rn;                       ///< near points in the sensor's frame
  detail::KnnTree tree;            ///< over rn
  double tolerance = 0.0;          ///< twice the median nearest-neighbour spacing of rn

  Impl(const Cloud& reference, const PreprocessParams& params, double max_range_m, int threads)
      : max_range(max_range_m),
        min_range(params.min_range_m),
        body_box(params.body_box),
        rd(reference) {
    rn = nearInSensorFrame(reference, rd.unique, min_range, max_range, parseBodyBox(body_box), &ri,
                           &mask);
    if (rn.size() < 2) return;
    tree = detail::KnnTree(rn, threads);
    std::vector<double> spacing = tree.kthNeighbourDistances(1, threads);
    std::nth_element(spacing.begin(), spacing.begin() + spacing.size() / 2, spacing.end());
    tolerance = 2.0 * spacing[spacing.size() / 2];
  }
  bool matches(const PreprocessParams& params, double max_range_m) const {
    return max_range == max_range_m && min_range == params.min_range_m &&
           body_box == params.body_box;
  }
};

struct SelfReturnReference::State {
  const Cloud* reference = nullptr;
  PreprocessParams params;
  int threads = 1;
  std::once_flag once;
  std::unique_ptr<Impl> impl;
};

SelfReturnReference::SelfReturnReference() = default;
SelfReturnReference::~SelfReturnReference() = default;
SelfReturnReference::SelfReturnReference(SelfReturnReference&&) noexcept = default;
SelfReturnReference& SelfReturnReference::operator=(SelfReturnReference&&) noexcept = default;

SelfReturnReference::SelfReturnReference(const Cloud& reference, const PreprocessParams& params,
                                         int threads) {
  if (!params.self_filter || !sensorOriginKnown(reference.sensor_origin_)) return;
  state_ = std::make_unique<State>();
  state_->reference = &reference;
  state_->params = params;
  state_->threads = threads;
}

const SelfReturnReference::Impl* SelfReturnReference::impl() const {
  if (!state_) return nullptr;
  // What a sweep that moved uses (max_range = self_max_range_m); one that did not makes its
  // own, without near points.
  std::call_once(state_->once, [this] {
    state_->impl = std::make_unique<Impl>(*state_->reference, state_->params,
                                          state_->params.self_max_range_m, state_->threads);
  });
  return state_->impl.get();
}

SelfReturns findSelfReturns(const Cloud& reference, const Cloud& current,
                            const PreprocessParams& params, double novelty_distance_m,
                            const NearestWithin& reference_within,
                            const NearestWithin& current_within, int threads,
                            const SelfReturnReference* prepared, int min_released) {
  SelfReturns s;
  s.current.assign(current.size(), 0);
  s.reference.assign(reference.size(), 0);
  const Eigen::AlignedBox3f body = parseBodyBox(params.body_box);
  if (!params.self_filter && params.min_range_m <= 0.0 && body.isEmpty()) return s;
  if (!sensorOriginKnown(reference.sensor_origin_) || !sensorOriginKnown(current.sensor_origin_))
    return s;
  s.checked = true;
  double max_range = params.self_filter ? params.self_max_range_m : 0.0;
  // A sensor that moved (and turned about up, at the filter's range) by less than the
  // novelty distance sees its robot within that distance of where it was: not a change
  // anyway. Only the turn about up counts: a tilting or nodding head pitches and rolls within
  // every sweep without its robot moving.
  const double moved =
      (current.sensor_origin_.head<3>() - reference.sensor_origin_.head<3>()).norm() +
      max_range * headingChange(reference.sensor_orientation_, current.sensor_orientation_);
  s.sought = moved >= novelty_distance_m && max_range > 0.0;
  if (!s.sought) {
    // Only min_range_m and body_box, without indexing either cloud's distinct points.
    markNearOrInBody(reference, params.min_range_m, body, &s.reference, &s.reference_count);
    markNearOrInBody(current, params.min_range_m, body, &s.current, &s.current_count);
    return s;
  }
  std::unique_ptr<SelfReturnReference::Impl> own;
  const SelfReturnReference::Impl* ref = prepared && s.sought ? prepared->impl() : nullptr;
  if (!ref || !ref->matches(params, max_range) || ref->mask.size() != reference.size()) {
    own = std::make_unique<SelfReturnReference::Impl>(reference, params, max_range, threads);
    ref = own.get();
  }
  s.reference = ref->mask;
  const Distinct cd(current);
  std::vector<int> ci;
  const Points& rn = ref->rn;
  const Points cn =
      nearInSensorFrame(current, cd.unique, params.min_range_m, max_range, body, &ci, &s.current);
  if (rn.size() >= 2 && cn.size() >= 2) {
    const detail::KnnTree& rn_tree = ref->tree;
    const detail::KnnTree cn_tree(cn, threads);
    s.tolerance_m = ref->tolerance;
    // Repeats of a position do not change a nearest distance: an index over every finite
    // reference point serves as well as one over the distinct ones.
    detail::KnnTree reference_map, current_map;
    if (!reference_within)
      reference_map = detail::KnnTree(pointsAt(reference, ref->rd.unique), threads);
    if (!current_within) current_map = detail::KnnTree(pointsAt(current, cd.unique), threads);
    const auto to_reference = [&](const Eigen::Vector3f& p, double r) {
      return reference_within ? reference_within(p, r) : reference_map.anyWithin(p, r);
    };
    const auto to_current = [&](const Eigen::Vector3f& p, double r) {
      return current_within ? current_within(p, r) : current_map.anyWithin(p, r);
    };
    const double nd = std::max(0.0, novelty_distance_m);
    markMatches(cn, ci, cn_tree, rn_tree, s.tolerance_m, nd, current, to_reference, threads,
                &s.current);
    markMatches(rn, ref->ri, rn_tree, cn_tree, s.tolerance_m, nd, reference, to_current, threads,
                &s.reference);
    if (nd > 0.0) {
      const double link = kLinkTolerances * s.tolerance_m;
      releaseReachingOut(cn, ci, cn_tree, nd, link, max_range, min_released, current, to_reference,
                         &s.current);
      releaseReachingOut(rn, ref->ri, rn_tree, nd, link, max_range, min_released, reference,
                         to_current, &s.reference);
    }
  }
  ref->rd.copyToRepeats(&s.reference);
  cd.copyToRepeats(&s.current);
  for (auto m : s.current) s.current_count += m;
  for (auto m : s.reference) s.reference_count += m;
  return s;
}

}  // namespace novelty_detection
