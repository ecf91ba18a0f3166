#include "reference_model.h"

#include "novelty_detection/alignment/alignment.h"
#include "novelty_detection/preprocess/input_check.h"
#include "novelty_detection/shape/superquadric.h"

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace novelty_detection {
namespace {

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

/// Throws std::invalid_argument unless `summary` can be the model of `cloud`.
void checkSummary(const ReferenceModelSummary& summary, const Cloud& cloud) {
  auto fail = [](const std::string& what) {
    throw std::invalid_argument("reference model summary does not fit the cloud: " + what);
  };
  int previous = -1;
  for (int i : summary.kept) {
    if (i <= previous || i >= static_cast<int>(cloud.size())) fail("point index out of order");
    if (!point3f(cloud[i]).allFinite()) fail("index of a non-finite point");
    previous = i;
  }
  for (const Gaussian& g : summary.gmm.components) {
    if (!(g.weight > 0) || !std::isfinite(g.weight) || !g.mean.allFinite() || !g.cov.allFinite())
      fail("a Gaussian with a non-positive weight or a non-finite value");
    if (Eigen::LLT<Eigen::Matrix3d>(g.cov).info() != Eigen::Success)
      fail("a Gaussian whose covariance is not positive definite");
  }
  if (std::isnan(summary.explained_log_density)) fail("the explained log-density is NaN");
}

Superquadric rotated(Superquadric sq, const Eigen::Matrix3d& R) {
  sq.position = R * sq.position;
  sq.euler = eulerZyzFromRotation(R * sq.rotation());
  return sq;
}

}  // namespace

Cloud rotateCloud(const Cloud& cloud, const Eigen::Matrix3d& R) {
  Cloud out = cloud;
  const Eigen::Matrix3f Rf = R.cast<float>();
  for (auto& p : out.points) p.getVector3fMap() = Rf * p.getVector3fMap();  // NaN stays NaN
  out.sensor_origin_.head<3>() = Rf * cloud.sensor_origin_.head<3>();
  out.sensor_orientation_ = Eigen::Quaternionf(Rf) * cloud.sensor_orientation_;
  return out;
}

Simplified simplify(const Params& params, const Cloud& cloud, Result* result, StageTimer* timer,
                    const PreprocessResult* earlier) {
  Simplified s;
  s.pre = Preprocessor(params.preprocess)
              .setThreads(params.compute.resolved())
              .setEarlier(earlier)
              .compute(cloud);
  if (result) {
    result->point_counts.emplace_back("finite", s.pre.finite.size());
    result->point_counts.emplace_back(
        "after_outliers", s.pre.finite.size() - s.pre.duplicates.size() - s.pre.outliers.size());
    result->point_counts.emplace_back("after_ground", s.pre.kept.size());
  }
  if (timer) timer->lap("preprocess");
  if (!s.pre.kept.empty()) {
    s.tree.build(cloud, s.pre.kept, params.compute.resolved());
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

std::shared_ptr<const ReferenceModel> buildReferenceModel(const Params& params, const Cloud& given,
                                                          const ReferenceViews& views,
                                                          const ReferenceModelSummary* summary) {
  checkReferenceViews(given, views);
  auto model = std::make_shared<ReferenceModel>();
  model->views = views;
  Cloud cleaned;
  const Cloud& reference = usableView(given, &cleaned, &model->out_of_range);
  requireExtent(reference, "reference");
  model->extent = usableExtent(reference);
  model->up = resolveUp(parseUp(params.preprocess.up), reference);
  model->rotated = model->up.up != Eigen::Vector3d::UnitZ();
  if (model->rotated) {
    model->R_up = rotationToZUp(model->up.up);
    model->given = reference;
    model->cloud = rotateCloud(reference, model->R_up);
    const Eigen::Matrix3f Rf = model->R_up.cast<float>();
    for (Eigen::Vector3f& o : model->views.origins) o = Rf * o;
  } else {
    model->cloud = reference;
  }
  return buildReferenceModelInUpFrame(params, std::move(model), summary);
}

std::shared_ptr<const ReferenceModel> buildReferenceModelInUpFrame(
    const Params& params, std::shared_ptr<ReferenceModel> model,
    const ReferenceModelSummary* summary) {
  const Cloud& reference = model->cloud;
  Simplified s;
  if (summary) {
    checkSummary(*summary, reference);
    s.pre.finite = finiteIndices(reference);
    s.pre.kept = summary->kept;
    model->gmm = summary->gmm;
  } else {
    s = simplify(params, reference, nullptr, nullptr);
    // The map's outlier index and statistics serve no later step: free them before the
    // model's own indexes are built.
    s.pre.distinct_index.reset();
    s.pre.statistics = {};
  }
  if (s.pre.kept.size() < 4) {
    throw std::invalid_argument("reference cloud has " + std::to_string(s.pre.kept.size()) +
                                " usable points after pre-processing; need at least 4");
  }
  const int threads = params.compute.resolved();
  if (!summary) {
    GmmFitter fitter(params.gmm);
    fitter.setThreads(threads);
    model->gmm = fitter.fit(s.reps);
  }
  model->points.build(reference, s.pre.finite, threads);
  if (model->views.empty())
    model->self_returns = SelfReturnReference(reference, params.preprocess, threads);
  if (params.alignment.enabled) model->planes.build(reference, params.alignment, s.pre.finite);
  const RangeImage::Config image_config = rangeImageConfig(params.visibility);
  if (!model->views.empty()) {
    // One image per sweep, of that sweep's finite points.
    std::vector<Indices> of_sweep(model->views.origins.size());
    for (int i : s.pre.finite) of_sweep[model->views.sweep[i]].push_back(i);
    for (std::size_t k = 0; k < of_sweep.size(); ++k) {
      if (of_sweep[k].empty()) continue;
      RangeImage image;
      image.build(reference, of_sweep[k], model->views.origins[k], image_config);
      model->visibility.add(std::move(image));
    }
  } else if (sensorOriginKnown(reference.sensor_origin_)) {
    RangeImage image;
    image.build(reference, s.pre.finite, reference.sensor_origin_.head<3>(), image_config);
    model->visibility.add(std::move(image));
  }
  model->kept = s.pre.kept;
  if (params.segmentation.hidden.segments) {
    model->structure.build(reference, s.pre.kept, threads);
    // Test 3 of the hidden-segment rule sums the structure about its points (hidden_segments.h).
    model->structure.prepareMoments();
  }
  if (summary) {
    model->explained_log_density = summary->explained_log_density;
  } else if (params.segmentation.map_likelihood_quantile > 0 && !model->gmm.empty()) {
    const std::size_t stride = std::max<std::size_t>(1, s.pre.kept.size() / 5000);
    std::vector<int> sample;
    for (std::size_t i = 0; i < s.pre.kept.size(); i += stride) sample.push_back(s.pre.kept[i]);
    Eigen::Matrix3Xd x(3, sample.size());
    for (std::size_t i = 0; i < sample.size(); ++i)
      x.col(i) = point3f(reference[sample[i]]).cast<double>();
    Eigen::VectorXd ll;
    responsibilities(model->gmm, x, &ll);
    std::vector<double> v(ll.data(), ll.data() + ll.size());
    const auto q = static_cast<std::ptrdiff_t>(params.segmentation.map_likelihood_quantile *
                                               static_cast<double>(v.size() - 1));
    std::nth_element(v.begin(), v.begin() + q, v.end());
    model->explained_log_density = v[q];
  }
  return model;
}

/// A result computed in the up frame, expressed in the input frame again (R_up^T): segments'
/// boxes are recomputed from the input points (boxes do not rotate), the rest rotates.
void toInputFrame(const ReferenceModel& ref, const Cloud& input, Result* r) {
  const Eigen::Matrix3d Rt = ref.R_up.transpose();
  if (r->alignment.applied) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Rt * r->alignment.correction.linear() * ref.R_up;
    T.translation() = Rt * r->alignment.correction.translation();
    r->alignment.correction = T;
  }
  const Cloud shown = r->alignment.applied ? transformCloud(input, r->alignment.correction) : input;
  auto reframe = [](const Cloud& cloud, std::vector<Segment>* segments) {
    for (Segment& s : *segments) {
      Segment t = makeSegment(cloud, std::move(s.indices), s.id);
      t.emd_contribution = s.emd_contribution;
      t.gaussians = std::move(s.gaussians);
      s = std::move(t);
    }
  };
  reframe(shown, &r->segments);
  reframe(ref.given, &r->disappeared_segments);
  for (Superquadric& sq : r->superquadrics) sq = rotated(std::move(sq), Rt);
  for (Superquadric& sq : r->disappeared_superquadrics) sq = rotated(std::move(sq), Rt);
  for (Gaussian& g : r->current_gmm.components) {
    g.mean = Rt * g.mean;
    g.cov = Rt * g.cov * ref.R_up;
  }
  if (r->floor_found) r->floor.head<3>() = Rt * r->floor.head<3>();
}

}  // namespace novelty_detection
