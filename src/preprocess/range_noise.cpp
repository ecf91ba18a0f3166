#include "novelty_detection/preprocess/range_noise.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace novelty_detection {

namespace {

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

}  // namespace

double RangeNoise::sigmaAt(double range_m) const {
  if (!estimated) return 0.0;
  if (exponent == 0.0) return scale;
  return scale * std::pow(std::max(range_m, 0.0), exponent);
}

std::string RangeNoise::modelName() const {
  if (exponent == 1.0) return "linear in range";
  if (exponent == 2.0) return "quadratic in range";
  return "constant";
}

RangeNoise estimateRangeNoise(const MultiScaleTree& tree, const Eigen::Vector3f* origin) {
  std::vector<double> log_sigma, log_range, range;
  for (const MultiScaleTree::Node& node : tree.nodes()) {
    const double var = MultiScaleTree::noiseVote(node);
    if (!(var > 0.0)) continue;  // not plate-like, or no thickness at all (duplicates)
    double r = 1.0;
    if (origin) {
      r = (node.centroid - *origin).norm();
      if (!(r > 1e-3)) continue;
    }
    log_sigma.push_back(0.5 * std::log(var));
    log_range.push_back(std::log(r));
    range.push_back(r);
  }
  RangeNoise out;
  out.votes = static_cast<int>(log_sigma.size());
  if (out.votes < kMinNoiseVotes) return out;
  out.estimated = true;
  int max_exponent = 0;
  if (origin) {
    std::sort(range.begin(), range.end());
    const double lo = range[range.size() / 10], hi = range[range.size() * 9 / 10];
    if (hi >= kMinRangeRatio * lo) max_exponent = 2;
  }
  double best_score = 0.0;
  std::vector<double> residual(log_sigma.size());
  for (int p = 0; p <= max_exponent; ++p) {
    for (std::size_t i = 0; i < residual.size(); ++i) residual[i] = log_sigma[i] - p * log_range[i];
    const double log_c = median(residual);
    for (double& e : residual) e = std::abs(e - log_c);
    const double score = median(residual);
    if (p == 0 || score < best_score) {
      best_score = score;
      out.exponent = p;
      out.scale = std::exp(log_c);
    }
  }
  return out;
}

}  // namespace novelty_detection
