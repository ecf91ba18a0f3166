#include "novelty_detection/shape_retrieval.h"

#include <limits>
#include <stdexcept>

#include "novelty_detection/split_merge.h"
#include "novelty_detection/superquadric.h"
#include "novelty_detection/superquadric_fit.h"

namespace novelty_detection {

ShapeRetrieval::ShapeRetrieval(const SuperquadricParams& params) : params_(params) {
  params_.validate();
}

std::vector<Superquadric> ShapeRetrieval::recover(const Points3d& fine, const Points3d& coarse,
                                                  int segment_id) const {
  if (!params_.enabled) return {};
  if (fine.empty()) {
    throw std::invalid_argument("ShapeRetrieval::recover: segment " +
                                std::to_string(segment_id) + " has no points");
  }
  const SuperquadricFitter fitter(params_);
  Indices sub_index;
  const Points3d sub = subsample(fine, params_.max_fit_points, &sub_index);

  // Multi-scale fitting (Sec. V-B): a fit on the coarse representatives refined on the finer
  // points, and a fit on the finer points from the moment initialisation; the lower mean
  // radial distance on the finer points wins.
  FitResult best = fitter.fit(sub);
  if (coarse.size() >= 11) {
    bool coarse_finite = true;
    for (const auto& p : coarse) coarse_finite = coarse_finite && p.allFinite();
    if (coarse_finite) {
      const FitResult refined = fitter.refine(sub, fitter.fit(coarse).sq);
      if (refined.mean_radial_distance < best.mean_radial_distance) best = refined;
    }
  }

  // Split and merge (Sec. V-C) on the subsampled points.
  const SplitMerge split_merge(params_);
  std::vector<SuperquadricPart> parts = split_merge.run(sub, &best);
  if (parts.size() == 1) parts.front().fit = best;

  // Every fine point goes to its part; points left out by the subsampling go to the part
  // whose surface is radially closest.
  std::vector<int> label(fine.size(), -1);
  for (std::size_t k = 0; k < parts.size(); ++k) {
    for (int i : parts[k].indices) label[static_cast<std::size_t>(sub_index[i])] = static_cast<int>(k);
  }
  std::vector<Superquadric> out(parts.size());
  std::vector<Points3d> part_points(parts.size());
  for (std::size_t i = 0; i < fine.size(); ++i) {
    int k = label[i];
    if (k < 0) {
      double best_d = std::numeric_limits<double>::infinity();
      for (std::size_t m = 0; m < parts.size(); ++m) {
        const double d = radialDistance(parts[m].fit.sq, fine[i]);
        if (d < best_d) {
          best_d = d;
          k = static_cast<int>(m);
        }
      }
    }
    out[k].indices.push_back(static_cast<int>(i));
    part_points[k].push_back(fine[i]);
  }
  for (std::size_t k = 0; k < parts.size(); ++k) {
    Indices indices = std::move(out[k].indices);
    out[k] = parts[k].fit.sq;
    out[k].indices = std::move(indices);
    out[k].segment = segment_id;
    out[k].points = static_cast<int>(out[k].indices.size());
    out[k].residual = meanSquaredResidual(out[k], part_points[k]);
  }
  return out;
}

}  // namespace novelty_detection
