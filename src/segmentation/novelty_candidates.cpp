// ChoosePtfromGaussian with the visibility rule (detail/novelty_candidates.h).
#include "segmentation/novelty_candidates.h"

namespace novelty_detection {
namespace detail {

NoveltyCandidates chooseNoveltyCandidates(const Cloud& current, const Indices& kept,
                                          const std::vector<int>& cluster_of,
                                          const WeightedPoints& reps, const Gmm& theta,
                                          const std::vector<int>& novel,
                                          const CandidateReference& reference, double tau,
                                          const Params& params) {
  NoveltyCandidates out;
  if (novel.empty()) return out;
  const double threshold = params.segmentation.posterior_threshold;
  const int threads = params.compute.resolved();
  // Each point's posterior mass on the novel Gaussians, and the novel one of most (-1 when
  // none has any), taken point by point: no K x N matrix of responsibilities.
  const auto novelMass = [&](const Eigen::Matrix3Xd& x, std::vector<double>* mass,
                             std::vector<int>* best_k) {
    mass->assign(static_cast<std::size_t>(x.cols()), 0.0);
    if (best_k) best_k->assign(static_cast<std::size_t>(x.cols()), -1);
    forEachResponsibility(theta, x, threads, [&](Eigen::Index i, const double* r, double) {
      double m = 0.0, best = -1.0;
      int arg = -1;
      for (int k : novel) {
        m += r[k];
        if (r[k] > best) best = r[k], arg = k;
      }
      (*mass)[static_cast<std::size_t>(i)] = m;
      if (best_k) (*best_k)[static_cast<std::size_t>(i)] = arg;
    });
  };
  // Posteriors of the representatives first: only points of clusters with some novel
  // posterior mass are evaluated one by one (a small fraction of the sweep).
  std::vector<double> cluster_mass;
  novelMass(reps.points, &cluster_mass, nullptr);
  std::vector<char> cluster_novel(static_cast<std::size_t>(reps.size()), 0);
  for (Eigen::Index c = 0; c < reps.size(); ++c)
    cluster_novel[static_cast<std::size_t>(c)] =
        cluster_mass[static_cast<std::size_t>(c)] > 0.1 * threshold;
  Indices todo;
  for (int i : kept) {
    const int c = cluster_of[static_cast<std::size_t>(i)];
    if (c >= 0 && cluster_novel[static_cast<std::size_t>(c)]) todo.push_back(i);
  }
  Eigen::Matrix3Xd x(3, todo.size());
  for (std::size_t i = 0; i < todo.size(); ++i)
    x.col(static_cast<Eigen::Index>(i)) = current[todo[i]].getVector3fMap().cast<double>();
  std::vector<double> mass;
  std::vector<int> best_k;
  novelMass(x, &mass, &best_k);
  Indices far_points;
  std::vector<int> far_owner;
  for (std::size_t i = 0; i < todo.size(); ++i) {
    if (mass[i] <= threshold) continue;
    if (reference.points->within(current[todo[i]].getVector3fMap(), tau)) continue;
    far_points.push_back(todo[i]);
    far_owner.push_back(best_k[i]);
  }
  // Far from every map point, but on a surface the map's mixture explains (e.g. between
  // the sparse tilt lines of the reference): not novel.
  Eigen::Matrix3Xd xf(3, far_points.size());
  for (std::size_t i = 0; i < far_points.size(); ++i)
    xf.col(static_cast<Eigen::Index>(i)) = current[far_points[i]].getVector3fMap().cast<double>();
  Eigen::VectorXd ll(static_cast<Eigen::Index>(far_points.size()));
  forEachResponsibility(*reference.gmm, xf, threads,
                        [&ll](Eigen::Index i, const double*, double lse) { ll[i] = lse; });
  // The fused rule of visibility.h (novelCandidate): free space -> novel; space the
  // reference never observed -> newly visible, unless the map's mixture cannot explain it.
  const bool use_visibility = params.segmentation.visibility_check && reference.visibility &&
                              !reference.visibility->empty();
  const double margin = params.visibility.margin_factor * tau;
  for (std::size_t i = 0; i < far_points.size(); ++i) {
    const Visibility v =
        use_visibility ? reference.visibility->classify(current[far_points[i]].getVector3fMap(),
                                                        margin, RangeImage::Neighbourhood::kOwnCell)
                       : Visibility::kUnknown;
    if (!novelCandidate(use_visibility, v,
                        ll[static_cast<Eigen::Index>(i)] >= reference.explained_log_density,
                        params.segmentation.hidden.unexplained)) {
      if (use_visibility) {
        out.hidden.push_back(far_points[i]);
        out.hidden_owner.push_back(far_owner[i]);
        out.hidden_vis.push_back(v);
      }
      continue;
    }
    out.novel.push_back(far_points[i]);
    out.owner.push_back(far_owner[i]);
  }
  return out;
}

}  // namespace detail
}  // namespace novelty_detection
