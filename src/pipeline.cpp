// The detection chain (paper Fig. 2), one named stage after another (Pipeline::detect):
// fine alignment -> pre-processing and the multi-scale cut -> distances to the map (tau) ->
// the current mixture (EM) -> greedy EMD selection (Algorithm 1) -> novel points and their
// segments -> disappearances -> hidden-space rules -> labels -> newly visible points ->
// superquadrics. The reference's model is built once by setReference().
#include "novelty_detection/pipeline.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/parallel.h"
#include "novelty_detection/alignment/alignment.h"
#include "novelty_detection/mixture/gmm.h"
#include "novelty_detection/mixture/novelty_selection.h"
#include "novelty_detection/preprocess/ignore_regions.h"
#include "novelty_detection/preprocess/input_check.h"
#include "novelty_detection/preprocess/range_noise.h"
#include "novelty_detection/preprocess/self_returns.h"
#include "novelty_detection/segmentation/hidden_segments.h"
#include "novelty_detection/segmentation/novelty_segmentation.h"
#include "novelty_detection/segmentation/object_completion.h"
#include "novelty_detection/segmentation/sparse_groups.h"
#include "novelty_detection/segmentation/surface_creases.h"
#include "novelty_detection/shape/shape_retrieval.h"
#include "novelty_detection/shape/superquadric.h"
#include "novelty_detection/visibility/disappearance.h"
#include "novelty_detection/visibility/visibility.h"
#include "reference_model.h"
#include "segmentation/novelty_candidates.h"

namespace novelty_detection {

namespace {

Eigen::Vector3f point3f(const PointT& p) { return Eigen::Vector3f(p.x, p.y, p.z); }

/// The current mixture Theta. With gmm/current_from_reference, the surfaces the map already
/// explains keep the map's Gaussians (EM on the weights only), so that the EMD measures
/// change rather than EM's local optima on two samplings of one scene; Gaussians for what
/// the map does not explain are fitted by EM on the fine clusters farther than tau from the
/// map; then the weights of the joint mixture are re-estimated on the whole sweep.
Gmm fitCurrent(const GmmParams& params, const WeightedPoints& reps, const Gmm& reference,
               const WeightedPoints& far, int threads) {
  GmmFitter fitter(params);
  fitter.setThreads(threads);
  if (!params.current_from_reference || reference.empty()) return fitter.fit(reps);
  Gmm init = reference;
  if (far.size() > 0 && params.max_extra_components > 0) {
    GmmParams extra_params = params;
    extra_params.max_components = params.max_extra_components;
    GmmFitter extra_fitter(extra_params);
    extra_fitter.setThreads(threads);
    const Gmm extra = extra_fitter.fit(far);
    for (const auto& g : extra.components) init.components.push_back(g);
  }
  for (auto& g : init.components) g.weight = 1.0 / static_cast<double>(init.size());
  return fitter.fitWeights(reps, init);
}

/// The state one detect() call hands from stage to stage.
struct Detection {
  Detection(const Params& p, const ReferenceModel& r, const Cloud& input)
      : params(p), ref(r), timer(result) {
    result.labels.assign(input.size(), 0);
    result.newly_visible.assign(input.size(), 0);
    result.disappeared_labels.assign(ref.cloud.size(), 0);
    result.point_counts.emplace_back("input", input.size());
  }
  const Params& params;
  const ReferenceModel& ref;
  Result result;
  StageTimer timer;
  Cloud aligned;                     ///< the sweep moved by the fine alignment, when applied
  const Cloud* current = nullptr;    ///< the sweep in the map frame (input or aligned)
  Cloud without_self;                ///< the sweep with its self-returns set to NaN, when any
  std::size_t self_returns = 0;      ///< current points taken for the robot
  Indices disappearance_candidates;  ///< ref.kept without the reference's self-returns
  Simplified s;
  double tau = 0.0;    ///< novelty distance from the data (novelty_segmentation.h)
  WeightedPoints far;  ///< fine clusters farther than tau from the map
  SelectionResult selection;
  detail::NoveltyCandidates candidates;
  std::vector<Indices> pieces;  ///< the segments' points, largest first
  std::vector<int> owner_of;    ///< per current point: its novel Gaussian, or -1
  double link_radius = 0.0;
  NearestNeighbourIndex kept_index;  ///< over s.pre.kept, in that order
  RangeNoise noise;                  ///< the sweep's range noise model (preprocess/range_noise.h)
  RangeImage current_view;           ///< the sweep from its own origin (when needed and known)
};

/// Fine alignment: every later stage sees the sweep in the map frame, in input order.
void alignToMap(const Cloud& input, Detection& d) {
  d.current = &input;
  if (!d.params.alignment.enabled || input.empty()) return;
  d.result.alignment = FineAligner(d.params.alignment).estimate(d.ref.planes, input);
  if (d.result.alignment.applied) {
    d.aligned = transformCloud(input, d.result.alignment.correction);
    d.current = &d.aligned;
  }
  d.timer.lap("alignment");
}

/// The robot's own returns (preprocess/self_returns.h), sought when the sensor moved by more
/// than the novelty distance (less, and they are no change anyway). The current ones become NaN
/// (labels keep the input order), the reference ones cannot disappear. Returns whether the sweep
/// changed (the stages so far must then run again).
bool markSelfReturns(Detection& d) {
  d.disappearance_candidates = d.ref.kept;
  const NearestNeighbourIndex& reference_points = d.ref.points;
  // The sweep's index from outlier removal holds its distinct finite points, as the test needs.
  const NearestNeighbourIndex* current_points = d.s.pre.distinct_index.get();
  NearestWithin current_within;
  if (current_points) {
    current_within = [current_points](const Eigen::Vector3f& p, double r) {
      return current_points->within(p, r);
    };
  }
  const SelfReturns self = findSelfReturns(
      d.ref.cloud, *d.current, d.params.preprocess, d.tau,
      [&reference_points](const Eigen::Vector3f& p, double r) {
        return reference_points.within(p, r);
      },
      current_within, d.params.compute.resolved(), &d.ref.self_returns);
  if (!self.checked) return false;
  d.self_returns = self.current_count;
  if (self.reference_count > 0) {
    Indices kept;
    for (int i : d.ref.kept)
      if (!self.reference[i]) kept.push_back(i);
    d.disappearance_candidates.swap(kept);
  }
  d.timer.lap("self_returns");
  if (self.current_count == 0) return false;
  d.without_self = *d.current;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (std::size_t i = 0; i < self.current.size(); ++i)
    if (self.current[i]) d.without_self[i].x = d.without_self[i].y = d.without_self[i].z = nan;
  d.without_self.is_dense = false;
  d.current = &d.without_self;
  return true;
}

/// Data scale: tau from the distances of a sample of current points to the map (Sec. IV-D
/// check), and the fine clusters farther than tau, which seed the extra Gaussians of Theta.
void measureDistancesToMap(Detection& d) {
  const Cloud& current = *d.current;
  const Indices& kept = d.s.pre.kept;
  std::vector<double> sample;
  const std::size_t stride = std::max<std::size_t>(1, kept.size() / 2000);
  // The same sample gives the sweep's median range (with a known origin), where tau's floor,
  // the sensor's own noise, is taken: tau then cannot collapse on a pair sampled at the same
  // pixels (near-zero distances everywhere).
  const bool origin_known = sensorOriginKnown(current.sensor_origin_);
  const Eigen::Vector3f origin = current.sensor_origin_.head<3>();
  std::vector<double> range;
  for (std::size_t i = 0; i < kept.size(); i += stride) {
    if (origin_known) range.push_back((point3f(current[kept[i]]) - origin).norm());
  }
  // The distances to the map, in blocks on compute/threads (each block its own slots).
  const int threads = d.params.compute.resolved();
  constexpr int kBlock = 512;
  sample.resize((kept.size() + stride - 1) / stride);
  const int n_sample = static_cast<int>(sample.size());
  detail::parallelForBlocks(n_sample, kBlock, threads, [&](int k) {
    sample[k] = d.ref.points.distance(point3f(current[kept[static_cast<std::size_t>(k) * stride]]));
  });
  d.noise = estimateRangeNoise(d.s.tree, origin_known ? &origin : nullptr);
  const RangeNoise& noise = d.noise;
  double median_range = 0.0;
  if (!range.empty()) {
    std::nth_element(range.begin(), range.begin() + range.size() / 2, range.end());
    median_range = range[range.size() / 2];
  }
  const double noise_sigma = noise.sigmaAt(median_range);
  const SegmentationParams& sp = d.params.segmentation;
  d.tau = noveltyDistanceThreshold(
      sample, sp.novelty_distance_factor,
      std::max(sp.min_novelty_distance_m, sp.noise_floor_factor * noise_sigma));
  d.result.tau_m = d.tau;
  d.result.noise_sigma_m = noise_sigma;
  d.result.noise_model = noise.estimated ? noise.modelName() : std::string();
  const int n_fine = static_cast<int>(d.s.fine.points.size());
  std::vector<char> far(static_cast<std::size_t>(n_fine), 0);
  detail::parallelForBlocks(n_fine, kBlock, threads, [&](int c) {
    far[c] = !d.ref.points.within(d.s.fine.points[c], d.tau);  // distance > tau, found sooner
  });
  std::vector<Eigen::Index> far_idx;
  for (int c = 0; c < n_fine; ++c)
    if (far[c]) far_idx.push_back(c);
  d.far.points.resize(3, far_idx.size());
  d.far.weights.resize(far_idx.size());
  for (std::size_t k = 0; k < far_idx.size(); ++k) {
    d.far.points.col(k) = d.s.fine.points[far_idx[k]].cast<double>();
    d.far.weights[k] = d.s.fine.sizes[far_idx[k]];
  }
  d.timer.lap("distances");
}

void fitCurrentMixture(Detection& d) {
  d.result.current_gmm =
      fitCurrent(d.params.gmm, d.s.reps, d.ref.gmm, d.far, d.params.compute.resolved());
  d.timer.lap("gmm");
}

/// Algorithm 1 with the stop rule of novelty_selection.h.
void selectNovelGaussians(Detection& d) {
  const SelectionParams& p = d.params.selection;
  const double u_th = std::max(p.u_th, p.u_th_noise_factor * d.tau);
  d.selection = GreedyNoveltySelector(p)
                    .setThreads(d.params.compute.resolved())
                    .select(d.result.current_gmm, d.ref.gmm, u_th);
  d.result.emd_before = d.selection.emd_before;
  d.result.emd_after = d.selection.emd_after;
  d.result.novel_gaussian.assign(d.result.current_gmm.size(), false);
  for (int k : d.selection.novel) d.result.novel_gaussian[k] = true;
  d.timer.lap("selection");
}

/// An index over cloud[pre.kept] (in that order): outlier removal's index over the distinct
/// points restricted to the kept ones when it covers them, else built.
NearestNeighbourIndex keptIndex(const Cloud& cloud, const PreprocessResult& pre, int threads) {
  const Indices& distinct = pre.statistics.points;  // the cloud index of each indexed point
  if (pre.distinct_index && distinct.size() == pre.distinct_index->size()) {
    std::vector<char> in_kept(cloud.size(), 0);
    for (int i : pre.kept) in_kept[static_cast<std::size_t>(i)] = 1;
    std::vector<char> keep(distinct.size(), 0);
    Indices order;  // the cloud indices of the restricted index's points, in its order
    order.reserve(pre.kept.size());
    for (std::size_t j = 0; j < distinct.size(); ++j) {
      if (!in_kept[static_cast<std::size_t>(distinct[j])]) continue;
      keep[j] = 1;
      order.push_back(distinct[j]);
    }
    if (order == pre.kept) return pre.distinct_index->restricted(keep);
  }
  NearestNeighbourIndex index;
  index.build(cloud, pre.kept, threads);
  return index;
}

/// ChoosePtfromGaussian (posterior mass of the novel Gaussians, the distance check and the
/// visibility rule: segmentation/novelty_candidates.h), then the novel points' segments
/// (linked pieces, merged per novel Gaussian: novelty_segmentation.h).
void segmentCandidates(Detection& d) {
  const Cloud& current = *d.current;
  detail::CandidateReference cref;
  cref.gmm = &d.ref.gmm;
  cref.points = &d.ref.points;
  cref.visibility = &d.ref.visibility;
  cref.explained_log_density = d.ref.explained_log_density;
  d.candidates = detail::chooseNoveltyCandidates(current, d.s.pre.kept, d.s.cut.cluster_of,
                                                 d.s.reps, d.result.current_gmm, d.selection.novel,
                                                 cref, d.tau, d.params);
  const detail::NoveltyCandidates& cand = d.candidates;
  d.result.point_counts.emplace_back("novel_points", cand.novel.size());
  const int num_gaussians = static_cast<int>(d.result.current_gmm.size());
  // One index over the kept points serves the link radius cap and the object completion.
  d.kept_index = keptIndex(current, d.s.pre, d.params.compute.resolved());
  SweepContext sweep;
  sweep.kept = &d.s.pre.kept;
  sweep.kept_index = &d.kept_index;
  sweep.origin_known = sensorOriginKnown(current.sensor_origin_);
  sweep.origin = current.sensor_origin_.head<3>();
  d.pieces = segmentNovelPoints(current, cand.novel, cand.owner, num_gaussians,
                                d.params.segmentation, &d.link_radius, sweep);
  d.owner_of.assign(current.size(), -1);
  for (std::size_t k = 0; k < cand.novel.size(); ++k) d.owner_of[cand.novel[k]] = cand.owner[k];
  d.timer.lap("segmentation");
}

/// Compact groups among the points outlier removal took (segmentation/sparse_groups.h): a
/// small far object sampled sparser than the statistic allows, standing in space the reference
/// saw through. Needs the sweep's origin (its spacing per metre of range) and the reference's
/// visibility (the free-space evidence); runs while outlier removal's statistics are at hand.
void addSparseGroups(Detection& d) {
  const Cloud& current = *d.current;
  const PreprocessResult& pre = d.s.pre;
  const SegmentationParams& sp = d.params.segmentation;
  if (!sp.sparse_groups || !sp.visibility_check || pre.outliers.empty() ||
      pre.statistics.points.empty() || !sensorOriginKnown(current.sensor_origin_) ||
      d.ref.visibility.empty())
    return;
  const Eigen::Vector3f origin = current.sensor_origin_.head<3>();
  const double ratio = spacingRatio(current, pre.statistics.points, pre.statistics.kth, origin);
  const GroundPlane& ground = pre.ground;
  const Eigen::Vector3d normal = ground.coefficients.head<3>();
  const double margin = d.params.visibility.margin_factor * d.tau;
  const auto changed = [&](const Eigen::Vector3f& p) {
    if (ground.found && std::abs(normal.dot(p.cast<double>()) + ground.coefficients[3]) <=
                            ground.threshold_m * normal.norm())
      return false;  // the floor's own band
    // Farther from the map than its own sampling spacing too: at that spacing the map's
    // surface could lie anywhere between its samples (a far wall a pose error shifted).
    const double spacing = ratio * (p - origin).norm();
    return !d.ref.points.within(p, std::max(d.tau, spacing)) &&
           d.ref.visibility.classify(p, margin, RangeImage::Neighbourhood::kOwnCell) ==
               Visibility::kFree;
  };
  SparseGroups groups = sparseNovelGroups(current, pre.outliers, d.pieces, changed, origin, ratio,
                                          sp.link_factor, sp.min_segment_points);
  for (std::size_t s = 0; s < d.pieces.size(); ++s)
    d.pieces[s].insert(d.pieces[s].end(), groups.joined[s].begin(), groups.joined[s].end());
  for (Indices& g : groups.segments) d.pieces.push_back(std::move(g));
  std::stable_sort(d.pieces.begin(), d.pieces.end(),
                   [](const Indices& a, const Indices& b) { return a.size() > b.size(); });
  d.timer.lap("sparse_groups");
}

bool hiddenSegmentRuleApplies(const Detection& d) {
  return d.params.segmentation.hidden.segments && !d.candidates.hidden.empty();
}

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
  if (hiddenSegmentRuleApplies(d)) {
    for (Indices& seg :
         novelHiddenSegments(*d.current, cand.hidden, cand.hidden_owner, cand.hidden_vis,
                             static_cast<int>(d.result.current_gmm.size()), d.ref.structure, gone,
                             d.tau, d.params, &d.current_view))
      d.pieces.push_back(std::move(seg));
    std::stable_sort(d.pieces.begin(), d.pieces.end(),
                     [](const Indices& a, const Indices& b) { return a.size() > b.size(); });
    d.timer.lap("hidden_segments");
  }
  if (d.params.segmentation.hidden.continuations) {
    // A revealed surface beside a segment is no part of it (hidden_segments.h).
    HiddenSegmentContext revealed;
    revealed.current = d.current;
    revealed.structure = &d.ref.structure;
    revealed.gone = &gone;
    revealed.tau = d.tau;
    growIntoHidden(*d.current, &d.pieces, cand.hidden, d.link_radius,
                   d.params.segmentation.hidden.max_growth, &revealed, &d.params.segmentation);
    d.timer.lap("hidden_continuations");
  }
  for (std::size_t k = 0; k < cand.hidden.size(); ++k)
    d.owner_of[cand.hidden[k]] = cand.hidden_owner[k];
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
      for (Superquadric& sq : shapes[job])
        for (int& k : sq.indices) k = seg.indices[k];  // into the input cloud
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

/// Pre-processing, the multi-scale cut, the floor and tau of the sweep as it stands;
/// `earlier`: the pre-processing of the sweep before its robot returns became NaN.
void simplifyAndMeasure(Detection& d, const PreprocessResult* earlier = nullptr) {
  d.s = simplify(d.params, *d.current, &d.result, &d.timer, earlier);
  const GroundPlane& ground = d.s.pre.ground;
  d.result.floor_found = ground.found;
  if (ground.found) d.result.floor = ground.coefficients;
  if (d.s.reps.size() > 0) measureDistancesToMap(d);
}

/// The chain on a sweep already turned into the up frame.
Result detectInUpFrame(const Params& params_, const ReferenceModel& ref, const Cloud& input) {
  Detection d(params_, ref, input);
  alignToMap(input, d);
  simplifyAndMeasure(d);
  if (d.s.reps.size() == 0) return std::move(d.result);  // empty or all-NaN: nothing is novel
  if (markSelfReturns(d)) {
    d.result.point_counts.resize(1);  // "input": the counts follow the sweep without them
    // Outlier statistics of points whose neighbourhoods lost no robot return carry over.
    const PreprocessResult first = std::move(d.s.pre);
    simplifyAndMeasure(d, &first);
    if (d.s.reps.size() == 0) return std::move(d.result);
  }
  d.result.point_counts.emplace_back("self_returns", d.self_returns);
  fitCurrentMixture(d);
  selectNovelGaussians(d);
  segmentCandidates(d);
  addSparseGroups(d);
  d.s.pre.distinct_index.reset();  // the index over the kept points was their last user
  d.s.pre.statistics = {};
  buildCurrentView(d);
  findDisappearedStructure(d);
  addHiddenNovelties(d);
  completeNewObjects(d);
  labelSegments(d);
  markNewlyVisible(d);
  fitSuperquadrics(d);
  return std::move(d.result);
}

}  // namespace

Pipeline::Pipeline(const Params& params) : params_(params) { params_.validate(); }
Pipeline::~Pipeline() = default;
Pipeline::Pipeline(Pipeline&&) noexcept = default;
Pipeline& Pipeline::operator=(Pipeline&&) noexcept = default;

Result Pipeline::detect(const Cloud& given) const {
  if (!reference_) throw std::logic_error("detect() called before setReference()");
  if (given.size() > static_cast<std::size_t>(params_.preprocess.max_points)) {
    throw std::invalid_argument("cloud has " + std::to_string(given.size()) +
                                " points, more than preprocess/max_points");
  }
  const ReferenceModel& ref = *reference_;
  // Absurd coordinates are missing points; a sweep off the map is refused.
  std::size_t out_of_range = 0;
  Cloud cleaned;
  const Cloud* view = &usableView(given, &cleaned, &out_of_range);
  // Ignore regions: their points are missing points too.
  const std::vector<IgnoreRegion> regions = parseIgnoreRegions(params_.preprocess.ignore_regions);
  std::size_t ignored = 0;
  if (!regions.empty()) {
    if (view != &cleaned) cleaned = given;
    ignored = maskIgnoreRegions(regions, cleaned);
    view = &cleaned;
  }
  const Cloud& input = *view;
  // Share of the sweep near the map: the floor of the distance is the one tau has.
  const double near_m = overlapDistance(ref.extent, params_.segmentation.min_novelty_distance_m);
  // The map's points are in the up frame, its extent in the input frame.
  const Eigen::Matrix3f R_up = ref.R_up.cast<float>();
  std::size_t usable = 0, near = 0;
  const std::size_t stride = std::max<std::size_t>(1, input.size() / 2000);
  for (std::size_t i = 0; i < input.size(); i += stride) {
    if (!usablePoint(input[i])) continue;
    ++usable;
    const Eigen::Vector3f p = point3f(input[i]);
    near += ref.points.within(ref.rotated ? Eigen::Vector3f(R_up * p) : p, near_m);
  }
  const double overlap = usable ? static_cast<double>(near) / usable : 1.0;
  requireOverlap(input, ref.extent, overlap);
  Result result = ref.rotated ? detectInUpFrame(params_, ref, rotateCloud(input, ref.R_up))
                              : detectInUpFrame(params_, ref, input);
  if (ref.rotated) toInputFrame(ref, input, &result);
  auto warn = [&](std::size_t n, const char* which) {
    if (n == 0) return;
    result.warnings.push_back(
        std::to_string(n) + " " + which + " points have a coordinate beyond " +
        std::to_string(static_cast<int>(kMaxCoordinateM)) + " m and were taken as missing");
  };
  warn(out_of_range, "sweep");
  warn(ref.out_of_range, "reference");
  result.up = ref.up.up;
  result.up_source = ref.up.source;
  result.overlap = overlap;
  result.ignored_points = ignored;
  result.ignored_disappearances = dropDisappearancesIn(regions, &result);
  result.visibility_checked = params_.segmentation.visibility_check && !ref.visibility.empty();
  result.disappearances_checked =
      params_.visibility.disappearances && sensorOriginKnown(input.sensor_origin_);
  return result;
}

void Pipeline::setReference(const Cloud& reference, const ReferenceViews& views) {
  reference_ = buildReferenceModel(params_, reference, views);
}

void Pipeline::setReference(const Cloud& reference, const ReferenceViews& views,
                            const ReferenceModelSummary& summary) {
  reference_ = buildReferenceModel(params_, reference, views, &summary);
}

ReferenceModelSummary Pipeline::referenceSummary() const {
  ReferenceModelSummary s;
  if (!reference_) return s;
  s.kept = reference_->kept;
  s.gmm = reference_->gmm;
  s.explained_log_density = reference_->explained_log_density;
  return s;
}

std::size_t Pipeline::referenceViewpoints() const {
  return reference_ ? reference_->visibility.views() : 0;
}

const Cloud& Pipeline::referenceCloud() const {
  if (!reference_) throw std::logic_error("no reference set");
  return reference_->rotated ? reference_->given : reference_->cloud;
}

const Gmm& Pipeline::referenceGmm() const {
  static const Gmm empty;
  return reference_ ? reference_->gmm : empty;
}

}  // namespace novelty_detection
