// The stages of the detection chain after the novel points (pipeline/detection.h): the
// current sweep's own view, disappearances, candidates the reference could not see, object
// completion, surfaces that turned, the labels, newly visible points and the superquadrics.
#include <algorithm>
#include <cstdint>
#include <memory>
#include <vector>

#include "common/parallel.h"
#include "novelty_detection/segmentation/free_continuations.h"
#include "novelty_detection/segmentation/hidden_segments.h"
#include "novelty_detection/segmentation/object_completion.h"
#include "novelty_detection/segmentation/surface_creases.h"
#include "novelty_detection/segmentation/turned_surfaces.h"
#include "novelty_detection/shape/shape_retrieval.h"
#include "novelty_detection/shape/superquadric.h"
#include "novelty_detection/visibility/disappearance.h"
#include "pipeline/detection.h"

namespace novelty_detection {
namespace stages {

namespace {

bool hiddenSegmentRuleApplies(const Detection& d) {
  return d.params.segmentation.hidden.segments && !d.candidates.hidden.empty();
}

}  // namespace

/// The current sweep from its own origin: disappearances and hidden segments both look
/// through it, so it is built once, and only when one of them will.
void buildCurrentView(Detection& d) {
  const Cloud& current = *d.current;
  const Eigen::Vector3f origin = current.sensor_origin_.head<3>();
  if (sensorOriginKnown(current.sensor_origin_) &&
      (d.params.visibility.disappearances || hiddenSegmentRuleApplies(d)))
    d.current_view.build(current, {}, origin, rangeImageConfig(d.params.visibility));
}

/// Reference structure the sweep now sees through (visibility/disappearance.h). Runs before
/// the hidden segments: their rule skips the reference points that left.
void findDisappearedStructure(Detection& d) {
  if (findDisappearances(d.params, d.ref.cloud, d.disappearance_candidates, *d.current, d.tau,
                         &d.result, &d.current_view))
    d.timer.lap("disappearances");
}

/// Candidates the reference could not see (segmentation/hidden_segments.h): whole segments
/// that stand in space (a door leaf swung into the old leaf's shadow), then hidden points
/// that continue a novel segment.
void addHiddenNovelties(Detection& d) {
  const detail::NoveltyCandidates& cand = d.candidates;
  if (cand.hidden.empty()) return;
  const Indices& kept = d.ref.kept;
  std::vector<std::uint8_t> gone(kept.size(), 0);  // per structure point
  for (std::size_t k = 0; k < kept.size(); ++k) gone[k] = d.result.disappeared_labels[kept[k]] > 0;
  const NearestNeighbourIndex gone_points = goneIndex(d.ref.structure, gone);
  if (hiddenSegmentRuleApplies(d)) {
    for (Indices& seg :
         novelHiddenSegments(*d.current, cand.hidden, cand.hidden_owner, cand.hidden_vis,
                             static_cast<int>(d.result.current_gmm.size()), d.ref.structure, gone,
                             d.tau, d.params, &d.current_view, &gone_points))
      d.pieces.push_back(std::move(seg));
    sortLargestFirst(&d.pieces);
    d.timer.lap("hidden_segments");
  }
  if (d.params.segmentation.hidden.continuations) {
    // A revealed surface beside a segment is no part of it (hidden_segments.h).
    HiddenSegmentContext revealed;
    revealed.current = d.current;
    revealed.structure = &d.ref.structure;
    revealed.gone = &gone;
    revealed.gone_points = &gone_points;
    revealed.tau = d.tau;
    growIntoHidden(*d.current, &d.pieces, cand.hidden, d.link_radius,
                   d.params.segmentation.hidden.max_growth, &revealed, &d.params.segmentation);
    d.timer.lap("hidden_continuations");
  }
  for (std::size_t k = 0; k < cand.hidden.size(); ++k)
    d.owner_of[cand.hidden[k]] = cand.hidden_owner[k];
}

/// Continuations into free space (segmentation/free_continuations.h): points the posterior
/// turned down that lie farther than tau from the map, in space the reference saw through,
/// join the segment they are linked to. Needs the reference's visibility.
void addFreeContinuations(Detection& d) {
  const SegmentationParams& sp = d.params.segmentation;
  if (!sp.free_continuations || !sp.visibility_check || d.ref.visibility.empty() ||
      d.pieces.empty())
    return;
  const Cloud& current = *d.current;
  const double margin = d.params.visibility.margin_factor * d.tau;
  const auto changed = [&](int i) {
    const Eigen::Vector3f p = current[i].getVector3fMap();
    return !d.ref.points.within(p, d.tau) &&
           d.ref.visibility.classify(p, margin, RangeImage::Neighbourhood::kOwnCell) ==
               Visibility::kFree;
  };
  // Segments sampled more sparsely than the sweep link at their own spacing.
  std::vector<double> radii;
  if (sp.own_spacing_links)
    radii = ownSpacingRadii(current, d.pieces, d.kept_index, sp.link_factor, d.link_radius,
                            sp.merge_gap_factor * d.link_radius);
  const std::size_t added =
      growIntoFreeSpace(current, d.s.pre.kept, d.kept_index, &d.pieces, d.link_radius,
                        kFreeMaxGrowth, changed, radii.empty() ? nullptr : &radii);
  d.result.point_counts.emplace_back("free_continuation_points", added);
  d.timer.lap("free_continuations");
}

/// Object completion (object_completion.h) once every rule has added its novel points:
/// a connected piece of the sweep made mostly of them is a new object and its segments take
/// all its points (those on a surface the map had, those the reference could not see behind
/// the old object it replaces, those the posterior turned down); objects that touch are
/// parted at the concave crease between them (surface_creases.h).
void completeNewObjects(Detection& d) {
  const Cloud& current = *d.current;
  const SegmentationParams& sp = d.params.segmentation;
  if (sp.object_share >= 1.0 || d.pieces.empty()) return;
  std::unique_ptr<CreaseTest> creases;
  if (sensorOriginKnown(current.sensor_origin_) && sp.crease_offset_factor > 0 &&
      d.noise.estimated) {
    // Points within half a link radius of a crease end a piece: no link jumps the crease.
    // Each test sums the points within crease_radius_factor link radii: whole subtrees of
    // the index at once.
    d.kept_index.prepareMoments();
    creases = std::make_unique<CreaseTest>(
        current, d.s.pre.kept, d.kept_index, current.sensor_origin_.head<3>(),
        sp.crease_radius_factor * d.link_radius, sp.crease_offset_factor,
        [&noise = d.noise](double r) { return noise.sigmaAt(r); }, 0.5 * d.link_radius);
    // The novel points' tests (most of what the pieces ask) ahead, on compute/threads.
    creases->prepareSegments(d.pieces, d.params.compute.resolved());
  }
  completeObjects(current, d.s.pre.kept, d.link_radius, sp.object_share, {}, &d.pieces,
                  &d.kept_index, creases.get(), sp.min_segment_points);
  d.timer.lap("objects");
}

/// Continuations across surfaces that turned (segmentation/turned_surfaces.h), after object
/// completion: points within tau of the map whose surface runs another way in the sweep than
/// in the map join the segment they are linked to (a leaf's part next to its hinge).
void addTurnedContinuations(Detection& d) {
  const SegmentationParams& sp = d.params.segmentation;
  if (!sp.turned_surfaces || d.pieces.empty() || d.ref.structure.empty()) return;
  const Cloud& current = *d.current;
  const double radius = sp.turned_radius_factor * d.link_radius;
  const auto changed = [&](int i) {
    const Eigen::Vector3f p = current[i].getVector3fMap();
    return d.ref.points.within(p, d.tau) &&
           surfaceTurned(p, d.kept_index, d.ref.structure, radius, sp.turned_angle_deg);
  };
  const std::size_t added = growIntoFreeSpace(current, d.s.pre.kept, d.kept_index, &d.pieces,
                                              d.link_radius, kFreeMaxGrowth, changed);
  d.result.point_counts.emplace_back("turned_continuation_points", added);
  if (added > 0) sortLargestFirst(&d.pieces);
  d.timer.lap("turned_continuations");
}

/// Segments from the pieces: ids 1.. largest first, labels per point, the Gaussians that
/// own their points and the EMD decrease those Gaussians earned.
void labelSegments(Detection& d) {
  Result& result = d.result;
  std::vector<double> decrease(result.current_gmm.size(), 0.0);
  for (std::size_t t = 0; t < d.selection.novel.size(); ++t)
    decrease[d.selection.novel[t]] = d.selection.decrease[t];
  for (const Indices& c : d.pieces) {
    Segment seg = makeSegment(*d.current, c, static_cast<int>(result.segments.size()) + 1);
    std::vector<int> votes(result.current_gmm.size(), 0);
    for (int i : seg.indices) {
      result.labels[i] = seg.id;
      if (d.owner_of[i] >= 0) ++votes[d.owner_of[i]];  // completed objects' points own none
    }
    for (std::size_t k = 0; k < votes.size(); ++k) {
      if (votes[k] > 0) {
        seg.gaussians.push_back(static_cast<int>(k));
        seg.emd_contribution += decrease[k];
      }
    }
    result.segments.push_back(std::move(seg));
  }
  labelDuplicates(d.s.pre.duplicates, d.s.pre.duplicate_of, result.labels, result.segments);
  std::size_t labelled = 0;
  if (!d.candidates.novel.empty())
    for (const auto& seg : result.segments) labelled += seg.indices.size();
  result.point_counts.emplace_back("labelled", labelled);
}

/// Current points far from the map in space the reference never observed (visibility.h).
void markNewlyVisible(Detection& d) {
  if (!d.params.visibility.newly_visible) return;
  const ReferenceModel& ref = d.ref;
  const double tau = d.tau;
  d.result.newly_visible = newlyVisible(
      *d.current, d.result.labels, ref.visibility, d.params.visibility.margin_factor * tau,
      [&ref, tau](const Eigen::Vector3f& p) { return !ref.points.within(p, tau); },
      d.params.compute.resolved());
  d.timer.lap("newly_visible");
}

namespace {

/// What bounds the segments' fits (shape/fit_bounds.h): the sweep, its labels, its view from
/// its own origin (built here when no earlier stage needed it) and its floor.
FitBoundsSource boundsSource(Detection& d) {
  FitBoundsSource source;
  if (!d.params.superquadric.bounded_fit) return source;
  const Cloud& current = *d.current;
  if (d.current_view.empty() && sensorOriginKnown(current.sensor_origin_))
    d.current_view.build(current, {}, current.sensor_origin_.head<3>(),
                         rangeImageConfig(d.params.visibility));
  source.sweep = &current;
  source.labels = &d.result.labels;
  source.view = &d.current_view;
  source.margin_m = d.tau;
  const GroundPlane& ground = d.s.pre.ground;
  source.has_floor = ground.found;
  source.floor = ground.coefficients;
  source.floor_band_m = ground.threshold_m;
  source.noise = &d.noise;
  return source;
}

}  // namespace

/// Shape retrieval (Sec. V) per segment, new and disappeared ones as one list of jobs on
/// compute/threads (a job alone keeps its inner parallel loops): a new segment's coarse
/// points are the cut's representatives inside it. A failed fit never loses the detection.
/// Results are appended in segment order whatever the threads.
void fitSuperquadrics(Detection& d) {
  const SuperquadricParams& p = d.params.superquadric;
  Result& result = d.result;
  const std::size_t news = p.enabled ? result.segments.size() : 0;
  const std::size_t gone = p.enabled ? result.disappeared_segments.size() : 0;
  if (news + gone == 0) return;
  const int threads = d.params.compute.resolved();
  const MultiScaleTree::Cut& fine_cut = d.s.fine;
  const FitBoundsSource source = news > 0 ? boundsSource(d) : FitBoundsSource();
  std::vector<std::vector<Superquadric>> shapes(news + gone);
  // The largest segments first: the threads then finish together more often (each job's
  // result does not depend on when it runs).
  std::vector<int> order(news + gone);
  std::vector<std::size_t> size(news + gone);
  for (std::size_t job = 0; job < news + gone; ++job) {
    order[job] = static_cast<int>(job);
    size[job] = job < news ? result.segments[job].indices.size()
                           : result.disappeared_segments[job - news].indices.size();
  }
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return size[a] > size[b]; });
  detail::parallelFor(static_cast<int>(news + gone), threads, [&](int k) {
    const int job = order[static_cast<std::size_t>(k)];
    ShapeRetrieval retrieval(p);  // one per job: its fitters keep statistics
    retrieval.setThreads(threads);
    if (static_cast<std::size_t>(job) >= news) {
      shapes[job] =
          disappearedShapes(retrieval, d.ref.cloud, result.disappeared_segments[job - news]);
      return;
    }
    const Segment& seg = result.segments[job];
    Points3d fine, coarse;
    fine.reserve(seg.indices.size());
    std::vector<char> seen(fine_cut.points.size(), 0);
    for (int i : seg.indices) {
      fine.push_back(point3f((*d.current)[i]).cast<double>());
      const int c = fine_cut.cluster_of[i];
      if (c >= 0 && !seen[c]) {
        seen[c] = 1;
        coarse.push_back(fine_cut.points[c].cast<double>());
      }
    }
    try {
      const FitBounds bounds = fitBoundsFor(fine, seg.id, source, p);
      shapes[job] = retrieval.recover(fine, coarse, seg.id, &bounds);
      for (Superquadric& sq : shapes[job]) {
        for (int& k : sq.indices) k = seg.indices[k];  // into the input cloud
        sq.support = bounds.support;
      }
    } catch (const std::exception&) {
      shapes[job].clear();  // keep the segment without a shape
    }
  });
  for (std::size_t job = 0; job < shapes.size(); ++job) {
    auto& into = job < news ? result.superquadrics : result.disappeared_superquadrics;
    for (Superquadric& sq : shapes[job]) into.push_back(std::move(sq));
  }
  d.timer.lap("superquadrics");
}

}  // namespace stages
}  // namespace novelty_detection
