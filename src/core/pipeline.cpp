// The detection chain (paper Fig. 2): pre-processing -> multi-scale cut -> GMM (EM) ->
// greedy EMD selection (Algorithm 1) -> per-point labels -> superquadrics.
#include "novelty_detection/pipeline.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "detail/novelty_candidates.h"
#include "novelty_detection/alignment.h"
#include "novelty_detection/disappearance.h"
#include "novelty_detection/gmm.h"
#include "novelty_detection/hidden_segments.h"
#include "novelty_detection/multiscale_tree.h"
#include "novelty_detection/novelty_segmentation.h"
#include "novelty_detection/novelty_selection.h"
#include "novelty_detection/preprocess.h"
#include "novelty_detection/shape_retrieval.h"
#include "novelty_detection/visibility.h"

namespace novelty_detection {

struct ReferenceModel {
  Cloud cloud;                      ///< as given
  Gmm gmm;                          ///< Gamma
  NearestNeighbourIndex points;     ///< every finite reference point (ground included)
  NearestNeighbourIndex structure;  ///< the points of `kept`, in that order
  RangeImage visibility;            ///< free / occupied / unknown seen from its viewpoint
  Indices kept;                     ///< points that may disappear (no ground, no outliers)
  AlignmentReference planes;        ///< map planes for the fine alignment (when enabled)
  /// Log-density under Gamma that all but a `map_likelihood_quantile` share of the map's own
  /// points reach: a current point above it is explained by the map's surfaces.
  /// +inf when the check is off (no point counts as explained).
  double explained_log_density = std::numeric_limits<double>::infinity();
};

namespace {

using Clock = std::chrono::steady_clock;

class StageTimer {
 public:
  explicit StageTimer(Result& r) : result_(r), start_(Clock::now()) {}
  void lap(const char* stage) {
    const auto now = Clock::now();
    result_.timings.push_back(
        {stage, std::chrono::duration<double, std::milli>(now - start_).count()});
    start_ = now;
  }

 private:
  Result& result_;
  Clock::time_point start_;
};

Eigen::Vector3f point3f(const PointT& p) { return Eigen::Vector3f(p.x, p.y, p.z); }

/// Multi-scale cut (Sec. IV-A) as weighted points: representative, cluster size, spread.
WeightedPoints cutAsWeightedPoints(const MultiScaleTree& tree, const MultiScaleTree::Cut& cut) {
  WeightedPoints w;
  const Eigen::Index n = static_cast<Eigen::Index>(cut.points.size());
  w.points.resize(3, n);
  w.weights.resize(n);
  w.covariances.resize(9, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    w.points.col(i) = cut.points[i].cast<double>();
    w.weights[i] = cut.sizes[i];
    const Eigen::Matrix3d c = tree.nodes()[cut.nodes[i]].covariance.cast<double>();
    w.covariances.col(i) = Eigen::Map<const Eigen::Matrix<double, 9, 1>>(c.data());
  }
  return w;
}

/// Pre-processing and the multi-scale cut of one cloud.
struct Simplified {
  PreprocessResult pre;
  MultiScaleTree tree;
  MultiScaleTree::Cut fine;  ///< the (n_max, sigma_max) cut: where new surfaces are sought
  MultiScaleTree::Cut cut;   ///< the scale EM is fitted at (fine, or coarser when too many)
  WeightedPoints reps;       ///< `cut` as weighted points
};

Simplified simplify(const Params& params, const Cloud& cloud, Result* result, StageTimer* timer) {
  Simplified s;
  s.pre = Preprocessor(params.preprocess).compute(cloud);
  if (result) {
    result->point_counts.emplace_back("finite", s.pre.finite.size());
    result->point_counts.emplace_back(
        "after_outliers", s.pre.finite.size() - s.pre.duplicates.size() - s.pre.outliers.size());
    result->point_counts.emplace_back("after_ground", s.pre.kept.size());
  }
  if (timer) timer->lap("preprocess");
  if (!s.pre.kept.empty()) {
    s.tree.build(cloud, s.pre.kept);
    // The scale the mixture is fitted at: the (n_max, sigma_max) cut, coarsened by size
    // alone when range noise makes sigma split nearly every cluster down to its leaves
    // (sigma of a noisy plane patch exceeds sigma_max). Each representative carries its
    // cluster's size and covariance, so EM still sees the full cloud's spread.
    const int n_max = std::max(params.multiscale.n_max, static_cast<int>(s.pre.kept.size()) /
                                                            std::max(1, params.gmm.max_fit_points));
    s.fine = s.tree.cut(params.multiscale.n_max, params.multiscale.sigma_max);
    s.cut = s.tree.cut(n_max, params.multiscale.sigma_max);
    if (static_cast<int>(s.cut.points.size()) > params.gmm.max_fit_points)
      s.cut = s.tree.cut(n_max, 1.0);
    s.reps = cutAsWeightedPoints(s.tree, s.cut);
  }
  if (result) {
    result->point_counts.emplace_back("clusters", s.fine.points.size());
    result->point_counts.emplace_back("gmm_clusters", s.cut.points.size());
  }
  if (timer) timer->lap("multiscale");
  return s;
}

/// The current mixture Theta. With gmm/current_from_reference, the surfaces the map already
/// explains keep the map's Gaussians (EM on the weights only), so that the EMD measures
/// change rather than EM's local optima on two samplings of one scene; Gaussians for what
/// the map does not explain are fitted by EM on the fine clusters farther than tau from the
/// map; then the weights of the joint mixture are re-estimated on the whole sweep.
Gmm fitCurrent(const GmmParams& params, const WeightedPoints& reps, const Gmm& reference,
               const WeightedPoints& far) {
  GmmFitter fitter(params);
  if (!params.current_from_reference || reference.empty()) return fitter.fit(reps);
  Gmm init = reference;
  if (far.size() > 0 && params.max_extra_components > 0) {
    GmmParams extra_params = params;
    extra_params.max_components = params.max_extra_components;
    const GmmFitter extra_fitter(extra_params);
    const Gmm extra = extra_fitter.fit(far);
    for (const auto& g : extra.components) init.components.push_back(g);
  }
  for (auto& g : init.components) g.weight = 1.0 / static_cast<double>(init.size());
  return fitter.fitWeights(reps, init);
}

Segment makeSegment(const Cloud& cloud, Indices indices, int id) {
  Segment s;
  s.id = id;
  s.indices = std::move(indices);
  s.bbox_min.setConstant(std::numeric_limits<double>::infinity());
  s.bbox_max.setConstant(-std::numeric_limits<double>::infinity());
  for (int i : s.indices) {
    const Eigen::Vector3d p = point3f(cloud[i]).cast<double>();
    s.centroid += p;
    s.bbox_min = s.bbox_min.cwiseMin(p);
    s.bbox_max = s.bbox_max.cwiseMax(p);
  }
  s.centroid /= static_cast<double>(s.indices.size());
  return s;
}

}  // namespace

Pipeline::Pipeline(const Params& params) : params_(params) { params_.validate(); }
Pipeline::~Pipeline() = default;
Pipeline::Pipeline(Pipeline&&) noexcept = default;
Pipeline& Pipeline::operator=(Pipeline&&) noexcept = default;

void Pipeline::setReference(const Cloud& reference) {
  auto model = std::make_shared<ReferenceModel>();
  model->cloud = reference;
  const Simplified s = simplify(params_, reference, nullptr, nullptr);
  if (s.pre.kept.size() < 4) {
    throw std::invalid_argument("reference cloud has " + std::to_string(s.pre.kept.size()) +
                                " usable points after pre-processing; need at least 4");
  }
  model->gmm = GmmFitter(params_.gmm).fit(s.reps);
  model->points.build(reference, s.pre.finite);
  if (params_.alignment.enabled) model->planes.build(reference, params_.alignment, s.pre.finite);
  const Eigen::Vector3f origin = reference.sensor_origin_.head<3>();
  if (sensorOriginKnown(origin))
    model->visibility.build(reference, s.pre.finite, origin, rangeImageConfig(params_.visibility));
  model->kept = s.pre.kept;
  if (params_.segmentation.hidden_segments) model->structure.build(reference, s.pre.kept);
  if (params_.segmentation.map_likelihood_quantile > 0 && !model->gmm.empty()) {
    const std::size_t stride = std::max<std::size_t>(1, s.pre.kept.size() / 5000);
    std::vector<int> sample;
    for (std::size_t i = 0; i < s.pre.kept.size(); i += stride) sample.push_back(s.pre.kept[i]);
    Eigen::Matrix3Xd x(3, sample.size());
    for (std::size_t i = 0; i < sample.size(); ++i)
      x.col(i) = point3f(reference[sample[i]]).cast<double>();
    Eigen::VectorXd ll;
    responsibilities(model->gmm, x, &ll);
    std::vector<double> v(ll.data(), ll.data() + ll.size());
    const auto q = static_cast<std::ptrdiff_t>(params_.segmentation.map_likelihood_quantile *
                                               static_cast<double>(v.size() - 1));
    std::nth_element(v.begin(), v.begin() + q, v.end());
    model->explained_log_density = v[q];
  }
  reference_ = model;
}

const Cloud& Pipeline::referenceCloud() const {
  if (!reference_) throw std::logic_error("no reference set");
  return reference_->cloud;
}

const Gmm& Pipeline::referenceGmm() const {
  static const Gmm empty;
  return reference_ ? reference_->gmm : empty;
}

Result Pipeline::detect(const Cloud& input) const {
  if (!reference_) throw std::logic_error("detect() called before setReference()");
  if (input.size() > static_cast<std::size_t>(params_.preprocess.max_points)) {
    throw std::invalid_argument("cloud has " + std::to_string(input.size()) +
                                " points, more than preprocess/max_points");
  }
  const ReferenceModel& ref = *reference_;
  Result result;
  result.labels.assign(input.size(), 0);
  result.newly_visible.assign(input.size(), 0);
  result.disappeared_labels.assign(ref.cloud.size(), 0);
  result.point_counts.emplace_back("input", input.size());
  StageTimer timer(result);
  // Fine alignment (issue 7): everything below sees the sweep in the map frame, in input order.
  Cloud aligned;
  if (params_.alignment.enabled && !input.empty()) {
    result.alignment = FineAligner(params_.alignment).estimate(ref.planes, input);
    if (result.alignment.applied) aligned = transformCloud(input, result.alignment.correction);
    timer.lap("alignment");
  }
  const Cloud& current = result.alignment.applied ? aligned : input;
  const Simplified s = simplify(params_, current, &result, &timer);
  if (s.reps.size() == 0) return result;  // empty or all-NaN: nothing can be novel

  // Data scale: distances from a sample of current points to the map (Sec. IV-D check).
  const Indices& kept = s.pre.kept;
  std::vector<double> sample;
  const std::size_t stride = std::max<std::size_t>(1, kept.size() / 2000);
  for (std::size_t i = 0; i < kept.size(); i += stride)
    sample.push_back(ref.points.distance(point3f(current[kept[i]])));
  const double tau = noveltyDistanceThreshold(sample, params_.segmentation.novelty_distance_factor,
                                              params_.segmentation.min_novelty_distance_m);
  // Fine clusters farther than tau from the map seed the extra Gaussians of Theta.
  std::vector<Eigen::Index> far_idx;
  for (std::size_t c = 0; c < s.fine.points.size(); ++c)
    if (ref.points.distance(s.fine.points[c]) > tau) far_idx.push_back(c);
  WeightedPoints far;
  far.points.resize(3, far_idx.size());
  far.weights.resize(far_idx.size());
  for (std::size_t k = 0; k < far_idx.size(); ++k) {
    far.points.col(k) = s.fine.points[far_idx[k]].cast<double>();
    far.weights[k] = s.fine.sizes[far_idx[k]];
  }
  timer.lap("distances");

  result.current_gmm = fitCurrent(params_.gmm, s.reps, ref.gmm, far);
  timer.lap("gmm");

  // Algorithm 1 with the stop rule of novelty_selection.h.
  const double u_th = std::max(params_.selection.u_th, params_.selection.u_th_noise_factor * tau);
  const SelectionResult sel =
      GreedyNoveltySelector(params_.selection).select(result.current_gmm, ref.gmm, u_th);
  result.emd_before = sel.emd_before;
  result.emd_after = sel.emd_after;
  result.novel_gaussian.assign(result.current_gmm.size(), false);
  for (int k : sel.novel) result.novel_gaussian[k] = true;
  timer.lap("selection");

  // ChoosePtfromGaussian: posterior mass of the novel Gaussians, the distance check and the
  // visibility rule (detail/novelty_candidates.h).
  detail::CandidateReference cref;
  cref.gmm = &ref.gmm;
  cref.points = &ref.points;
  cref.visibility = &ref.visibility;
  cref.explained_log_density = ref.explained_log_density;
  detail::NoveltyCandidates cand = detail::chooseNoveltyCandidates(
      current, kept, s.cut.cluster_of, s.reps, result.current_gmm, sel.novel, cref, tau, params_);
  const Indices& novel_points = cand.novel;
  const std::vector<int>& owner = cand.owner;
  const Indices& hidden_points = cand.hidden;
  const std::vector<int>& hidden_owner = cand.hidden_owner;
  const std::vector<Visibility>& hidden_vis = cand.hidden_vis;
  result.point_counts.emplace_back("novel_points", novel_points.size());
  // Segments (novelty_segmentation.h: linked pieces, merged per novel Gaussian).
  double link_radius = 0.0;
  const int num_gaussians = static_cast<int>(result.current_gmm.size());
  std::vector<Indices> comps = segmentNovelPoints(current, novel_points, owner, num_gaussians,
                                                  params_.segmentation, &link_radius);
  std::vector<int> owner_of(current.size(), -1);
  for (std::size_t k = 0; k < novel_points.size(); ++k) owner_of[novel_points[k]] = owner[k];
  timer.lap("segmentation");
  // The current sweep from its own origin: disappearances and hidden segments both look
  // through it (built once).
  const bool hidden_rule = params_.segmentation.hidden_segments && !hidden_points.empty();
  RangeImage current_view;
  if (sensorOriginKnown(current.sensor_origin_.head<3>()) &&
      (params_.visibility.disappearances || hidden_rule))
    current_view.build(current, {}, current.sensor_origin_.head<3>(),
                       rangeImageConfig(params_.visibility));
  // Disappearances before the hidden segments: the rule skips the reference points that left.
  const bool checked_disappearances =
      findDisappearances(params_, ref.cloud, ref.kept, current, tau, &result, &current_view);
  if (checked_disappearances) timer.lap("disappearances");
  if (hidden_rule) {
    std::vector<std::uint8_t> gone(ref.kept.size(), 0);  // per structure point
    for (std::size_t k = 0; k < ref.kept.size(); ++k)
      gone[k] = result.disappeared_labels[ref.kept[k]] > 0;
    for (Indices& seg :
         novelHiddenSegments(current, hidden_points, hidden_owner, hidden_vis, num_gaussians,
                             ref.structure, gone, tau, params_, &current_view))
      comps.push_back(std::move(seg));
    std::stable_sort(comps.begin(), comps.end(),
                     [](const Indices& a, const Indices& b) { return a.size() > b.size(); });
    timer.lap("hidden_segments");
  }
  if (params_.segmentation.hidden_continuations && !hidden_points.empty()) {
    growIntoHidden(current, &comps, hidden_points, link_radius);
    timer.lap("hidden_continuations");
  }
  for (std::size_t k = 0; k < hidden_points.size(); ++k)
    owner_of[hidden_points[k]] = hidden_owner[k];
  std::vector<double> decrease(result.current_gmm.size(), 0.0);
  for (std::size_t t = 0; t < sel.novel.size(); ++t) decrease[sel.novel[t]] = sel.decrease[t];
  for (const Indices& c : comps) {
    Segment seg = makeSegment(current, c, static_cast<int>(result.segments.size()) + 1);
    std::vector<int> votes(result.current_gmm.size(), 0);
    for (int i : seg.indices) {
      result.labels[i] = seg.id;
      ++votes[owner_of[i]];
    }
    for (std::size_t k = 0; k < votes.size(); ++k) {
      if (votes[k] > 0) {
        seg.gaussians.push_back(static_cast<int>(k));
        seg.emd_contribution += decrease[k];
      }
    }
    result.segments.push_back(std::move(seg));
  }
  labelDuplicates(s.pre.duplicates, s.pre.duplicate_of, result.labels, result.segments);
  result.point_counts.emplace_back(
      "labelled", novel_points.empty() ? 0 : [&] {
        std::size_t n = 0;
        for (const auto& seg : result.segments) n += seg.indices.size();
        return n;
      }());
  if (params_.visibility.newly_visible) {
    result.newly_visible =
        newlyVisible(current, result.labels, ref.visibility, params_.visibility.margin_factor * tau,
                     tau, [&ref](const Eigen::Vector3f& p) { return ref.points.distance(p); });
    timer.lap("newly_visible");
  }

  // Shape retrieval (Sec. V) per segment: the cut's representatives inside the segment are
  // the coarse points. A failed fit never loses the detection.
  if (params_.superquadric.enabled && !result.segments.empty()) {
    ShapeRetrieval retrieval(params_.superquadric);
    retrieval.setThreads(params_.compute.resolved());
    for (const Segment& seg : result.segments) {
      Points3d fine, coarse;
      fine.reserve(seg.indices.size());
      std::vector<char> seen(s.fine.points.size(), 0);
      for (int i : seg.indices) {
        fine.push_back(point3f(current[i]).cast<double>());
        const int c = s.fine.cluster_of[i];
        if (c >= 0 && !seen[c]) {
          seen[c] = 1;
          coarse.push_back(s.fine.points[c].cast<double>());
        }
      }
      try {
        for (Superquadric sq : retrieval.recover(fine, coarse, seg.id)) {
          for (int& k : sq.indices) k = seg.indices[k];  // into the input cloud
          result.superquadrics.push_back(std::move(sq));
        }
      } catch (const std::exception&) {
        // Keep the segment without a shape.
      }
    }
    timer.lap("superquadrics");
  }
  if (params_.superquadric.enabled && !result.disappeared_segments.empty()) {
    fitDisappearedSuperquadrics(params_.superquadric, ref.cloud, &result);
    timer.lap("disappeared_superquadrics");
  }
  return result;
}

}  // namespace novelty_detection
