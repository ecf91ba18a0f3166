#include "novelty_detection/visibility/disappearance.h"

#include <algorithm>
#include <exception>
#include <limits>

#include "common/parallel.h"
#include "novelty_detection/segmentation/novelty_segmentation.h"
#include "novelty_detection/shape/shape_retrieval.h"
#include "novelty_detection/visibility/visibility.h"

namespace novelty_detection {

bool findDisappearances(const Params& params, const Cloud& reference, const Indices& candidates,
                        const Cloud& current, double tau_m, Result* result,
                        const RangeImage* current_image) {
  result->disappeared_labels.assign(reference.size(), 0);
  result->disappeared_segments.clear();
  result->disappeared_superquadrics.clear();
  const Eigen::Vector3f origin = current.sensor_origin_.head<3>();
  if (!params.visibility.disappearances || !sensorOriginKnown(current.sensor_origin_) ||
      candidates.empty() || current.empty())
    return false;
  RangeImage own;
  if (!current_image) own.build(current, {}, origin, rangeImageConfig(params.visibility));
  const RangeImage& image = current_image ? *current_image : own;
  if (image.empty()) return false;
  const double margin = params.visibility.disappearance_margin_factor * tau_m;
  // Each candidate classified on its own (blocks of them on compute/threads), then taken in
  // order.
  std::vector<char> seen_free(candidates.size(), 0);
  constexpr int kBlock = 2048;
  detail::parallelForBlocks(
      static_cast<int>(candidates.size()), kBlock, params.compute.resolved(), [&](int k) {
        seen_free[k] =
            image.classify(reference[candidates[k]].getVector3fMap(), margin) == Visibility::kFree;
      });
  Indices seen_through;
  for (std::size_t k = 0; k < candidates.size(); ++k)
    if (seen_free[k]) seen_through.push_back(candidates[k]);
  // Connected pieces, then pieces whose bounding boxes lie within merge_gap_factor link
  // radii merge: one object seen through the gaps between the current sweep's lines (as
  // for the novelty segments, without the Gaussian ownership, which the reference lacks).
  double link_radius = 0.0;
  const std::vector<Indices> pieces =
      linkComponents(reference, seen_through, params.segmentation.link_factor, 1, &link_radius);
  const std::size_t np = pieces.size();
  std::vector<int> parent(np);
  std::vector<Eigen::Vector3f> lo(np), hi(np);
  for (std::size_t a = 0; a < np; ++a) {
    parent[a] = static_cast<int>(a);
    lo[a].setConstant(std::numeric_limits<float>::infinity());
    hi[a] = -lo[a];
    for (int i : pieces[a]) {
      lo[a] = lo[a].cwiseMin(reference[i].getVector3fMap());
      hi[a] = hi[a].cwiseMax(reference[i].getVector3fMap());
    }
  }
  auto find = [&parent](int a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  const float gap = static_cast<float>(params.segmentation.merge_gap_factor * link_radius);
  for (std::size_t a = 0; a < np; ++a) {
    for (std::size_t b = a + 1; b < np; ++b) {
      const Eigen::Vector3f sep =
          (lo[b] - hi[a]).cwiseMax(lo[a] - hi[b]).cwiseMax(Eigen::Vector3f::Zero());
      if (sep.norm() <= gap) parent[find(static_cast<int>(a))] = find(static_cast<int>(b));
    }
  }
  std::vector<Indices> merged(np), comps;
  for (std::size_t a = 0; a < np; ++a) {
    Indices& m = merged[find(static_cast<int>(a))];
    m.insert(m.end(), pieces[a].begin(), pieces[a].end());
  }
  for (Indices& c : merged) {
    if (static_cast<int>(c.size()) < params.visibility.min_disappeared_points) continue;
    std::sort(c.begin(), c.end());
    comps.push_back(std::move(c));
  }
  std::stable_sort(comps.begin(), comps.end(),
                   [](const Indices& a, const Indices& b) { return a.size() > b.size(); });
  for (const Indices& c : comps) {
    Segment seg =
        makeSegment(reference, c, static_cast<int>(result->disappeared_segments.size()) + 1);
    for (int i : seg.indices) result->disappeared_labels[i] = seg.id;
    result->disappeared_segments.push_back(std::move(seg));
  }
  return true;
}

std::vector<Superquadric> disappearedShapes(const ShapeRetrieval& retrieval, const Cloud& reference,
                                            const Segment& seg) {
  Points3d fine, coarse;
  fine.reserve(seg.indices.size());
  for (int i : seg.indices) fine.push_back(reference[i].getVector3fMap().cast<double>());
  // No multi-scale cut of the reference is kept: an even subsample (about one point in
  // eight, the cut's typical thinning on walls and objects) plays the coarse scale.
  const std::size_t stride = fine.size() >= 88 ? 8 : 1;
  for (std::size_t k = 0; k < fine.size(); k += stride) coarse.push_back(fine[k]);
  std::vector<Superquadric> out;
  try {
    out = retrieval.recover(fine, coarse, seg.id);
  } catch (const std::exception&) {
    return {};  // keep the disappearance without a shape
  }
  for (Superquadric& sq : out)
    for (int& k : sq.indices) k = seg.indices[k];  // into the reference cloud
  return out;
}

void fitDisappearedSuperquadrics(const SuperquadricParams& params, const Cloud& reference,
                                 Result* result) {
  result->disappeared_superquadrics.clear();
  if (!params.enabled) return;
  const ShapeRetrieval retrieval(params);
  for (const Segment& seg : result->disappeared_segments) {
    for (Superquadric& sq : disappearedShapes(retrieval, reference, seg))
      result->disappeared_superquadrics.push_back(std::move(sq));
  }
}

}  // namespace novelty_detection
