// The sweep's own stages of the detection chain (pipeline/detection.h): fine alignment,
// pre-processing and the multi-scale cut, the robot's returns, the distances to the map (tau),
// the current mixture, the greedy EMD selection, the novel points and their segments, and the
// compact groups among the removed outliers.
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "common/parallel.h"
#include "novelty_detection/alignment/alignment.h"
#include "novelty_detection/preprocess/self_returns.h"
#include "novelty_detection/segmentation/sparse_groups.h"
#include "pipeline/detection.h"

namespace novelty_detection {
namespace stages {

namespace {

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

}  // namespace

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
      current_within, d.params.compute.resolved(), &d.ref.self_returns,
      d.params.segmentation.min_segment_points);
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

namespace {

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

}  // namespace

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

namespace {

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

}  // namespace

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
/// saw through; then the free-standing groups among the kept points no segment holds (a far
/// object no selected Gaussian owns). Needs the sweep's origin (its spacing per metre of
/// range) and the reference's visibility (the free-space evidence); runs while outlier
/// removal's statistics are at hand.
void addSparseGroups(Detection& d) {
  const Cloud& current = *d.current;
  const PreprocessResult& pre = d.s.pre;
  const SegmentationParams& sp = d.params.segmentation;
  const bool sparse = sp.sparse_groups && !pre.outliers.empty();
  if (!(sparse || sp.free_groups) || !sp.visibility_check || pre.statistics.points.empty() ||
      !sensorOriginKnown(current.sensor_origin_) || d.ref.visibility.empty())
    return;
  const Eigen::Vector3f origin = current.sensor_origin_.head<3>();
  const double ratio = spacingRatio(current, pre.statistics.points, pre.statistics.kth, origin);
  const GroundPlane& ground = pre.ground;
  const Eigen::Vector3d normal = ground.coefficients.head<3>();  // unit (ground_plane.cpp)
  const double margin = d.params.visibility.margin_factor * d.tau;
  const auto changed = [&](const Eigen::Vector3f& p) {
    if (ground.found &&
        std::abs(normal.dot(p.cast<double>()) + ground.coefficients[3]) <= ground.threshold_m)
      return false;  // the floor's own band
    // Farther from the map than its own sampling spacing too: at that spacing the map's
    // surface could lie anywhere between its samples (a far wall a pose error shifted).
    const double spacing = ratio * (p - origin).norm();
    return !d.ref.points.within(p, std::max(d.tau, spacing)) &&
           d.ref.visibility.classify(p, margin, RangeImage::Neighbourhood::kOwnCell) ==
               Visibility::kFree;
  };
  if (sparse) {
    SparseGroups groups = sparseNovelGroups(current, pre.outliers, d.pieces, changed, origin, ratio,
                                            sp.link_factor, sp.min_segment_points);
    std::size_t restored = 0;
    for (std::size_t s = 0; s < d.pieces.size(); ++s) {
      d.pieces[s].insert(d.pieces[s].end(), groups.joined[s].begin(), groups.joined[s].end());
      restored += groups.joined[s].size();
    }
    for (Indices& g : groups.segments) {
      restored += g.size();
      d.pieces.push_back(std::move(g));
    }
    d.result.point_counts.emplace_back("sparse_group_points", restored);
  }
  if (sp.free_groups) {
    // The kept points no segment holds: a far object no selected Gaussian owns.
    std::vector<char> taken(current.size(), 0);
    for (const Indices& piece : d.pieces)
      for (int i : piece) taken[static_cast<std::size_t>(i)] = 1;
    // Which of them changed, on compute/threads (each its own slot); the groups then take
    // those alone.
    const int n_kept = static_cast<int>(pre.kept.size());
    std::vector<char> changed_kept(pre.kept.size(), 0);
    detail::parallelForBlocks(n_kept, 512, d.params.compute.resolved(), [&](int k) {
      const int i = pre.kept[static_cast<std::size_t>(k)];
      changed_kept[static_cast<std::size_t>(k)] =
          !taken[static_cast<std::size_t>(i)] && changed(current[i].getVector3fMap());
    });
    Indices loose;
    for (int k = 0; k < n_kept; ++k)
      if (changed_kept[static_cast<std::size_t>(k)]) loose.push_back(pre.kept[k]);
    SparseGroups free = sparseNovelGroups(
        current, loose, {}, [](const Eigen::Vector3f&) { return true; }, origin, ratio,
        sp.link_factor, sp.min_segment_points, GroupShape::kStands);
    std::size_t grouped = 0;
    for (Indices& g : free.segments) {
      grouped += g.size();
      d.pieces.push_back(std::move(g));
    }
    d.result.point_counts.emplace_back("free_group_points", grouped);
  }
  sortLargestFirst(&d.pieces);
  d.timer.lap("sparse_groups");
}

/// Pre-processing, the multi-scale cut, the floor and tau of the sweep as it stands;
/// `earlier`: the pre-processing of the sweep before its robot returns became NaN.
void simplifyAndMeasure(Detection& d, const PreprocessResult* earlier) {
  d.s = simplify(d.params, *d.current, &d.result, &d.timer, earlier);
  const GroundPlane& ground = d.s.pre.ground;
  d.result.floor_found = ground.found;
  if (ground.found) d.result.floor = ground.coefficients;
  if (d.s.reps.size() > 0) measureDistancesToMap(d);
}

}  // namespace stages
}  // namespace novelty_detection
