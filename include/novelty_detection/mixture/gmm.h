// Gaussian mixture fitting by Expectation-Maximisation (paper Sec. IV-B). ROS-free.
//
// Points are columns of a 3xN matrix with optional non-negative weights (e.g. the
// multi-scale cut's representatives weighted by their cluster sizes) and optional per-point
// covariances (the spread of each cluster around its representative), so that a mixture
// fitted on a few thousand representatives describes the full cloud.
//
// EM with full covariances:
//   E-step: r_nk = softmax_k(log pi_k + log N(x_n | mu_k, S_k)), computed with log-sum-exp.
//   M-step: N_k = sum_n w_n r_nk; pi_k = N_k / sum_n w_n; mu_k = sum_n w_n r_nk x_n / N_k;
//           S_k = sum_n w_n r_nk ((x_n - mu_k)(x_n - mu_k)^T + C_n) / N_k + min_variance * I.
//   The ridge min_variance * I keeps S_k positive definite on planar or collinear clusters.
//   A component whose mass N_k falls below 1e-9 of the total is dropped (weights renormalised).
// Convergence: stop when the weighted mean log-likelihood gains less than `tolerance` (nats
// per unit weight) between iterations, or after `max_iterations`.
// Number of components: K = clamp(ceil(W / points_per_component), 1, max_components), W the
// total weight, and never more than the number of points with positive weight.
// Initialisation: k-means++ (seeded, deterministic) followed by a few Lloyd steps, or given
// labels, or a given mixture.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <vector>

#include "novelty_detection/params.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

/// Weighted point set used for fitting. `weights` empty = all 1; `covariances` empty = none,
/// else 9xN, column n holds C_n (column-major 3x3).
struct WeightedPoints {
  Eigen::Matrix3Xd points;
  Eigen::VectorXd weights;
  Eigen::Matrix<double, 9, Eigen::Dynamic> covariances;

  Eigen::Index size() const { return points.cols(); }
  double weight(Eigen::Index n) const { return weights.size() ? weights[n] : 1.0; }
  double totalWeight() const;
};

struct EmStats {
  int iterations = 0;
  double log_likelihood = 0.0;  ///< weighted mean log-likelihood at the end
  bool converged = false;
};

class GmmFitter {
 public:
  explicit GmmFitter(const GmmParams& params);

  /// The stated rule for the number of components (see file comment).
  int numComponents(const WeightedPoints& data) const;

  /// k-means++ (seed from params) + Lloyd steps, then EM. k <= 0 uses numComponents().
  Gmm fit(const WeightedPoints& data, int k = 0, EmStats* stats = nullptr) const;

  /// EM started from `init` (its weights, means, covariances). Components may be dropped.
  Gmm fitFrom(const WeightedPoints& data, const Gmm& init, EmStats* stats = nullptr) const;

  /// EM on the weights alone: means and covariances of `init` stay fixed (used to express
  /// the current sweep in the map's Gaussians). Same convergence rule; no component dropped.
  Gmm fitWeights(const WeightedPoints& data, const Gmm& init, EmStats* stats = nullptr) const;

  /// Mixture whose component k is the weighted moments of the points with label k
  /// (labels in [0, k), negative = ignored). Empty labels are skipped.
  Gmm initFromLabels(const WeightedPoints& data, const std::vector<int>& labels, int k) const;

  /// Seeded k-means++ labels with `lloyd_iterations` refinement steps.
  std::vector<int> kmeansLabels(const WeightedPoints& data, int k, int lloyd_iterations = 5) const;

  /// Threads for the E-steps (blocks of points); the result is the same for any count.
  void setThreads(int threads) { threads_ = threads < 1 ? 1 : threads; }

 private:
  GmmParams params_;
  int threads_ = 1;
};

/// log(pi_k) + log N(x_n | k) as a K x N matrix. Points are taken in fixed blocks, the
/// blocks on up to `threads` threads: the result is the same for any count.
Eigen::MatrixXd logWeightedDensities(const Gmm& gmm, const Eigen::Matrix3Xd& points,
                                     int threads = 1);

/// Posterior responsibilities r_nk (K x N, columns sum to 1), via log-sum-exp.
/// `log_likelihood` (optional) receives log p(x_n) per point. Threads as above.
Eigen::MatrixXd responsibilities(const Gmm& gmm, const Eigen::Matrix3Xd& points,
                                 Eigen::VectorXd* log_likelihood = nullptr, int threads = 1);

/// responsibilities() point by point, without the K x N matrix: visit(n, r, lse) receives
/// point n's K responsibilities (the values of column n) and its log p(x_n). Blocks of points
/// run on up to `threads` threads: `visit` may be called concurrently (for distinct n).
void forEachResponsibility(const Gmm& gmm, const Eigen::Matrix3Xd& points, int threads,
                           const std::function<void(Eigen::Index, const double*, double)>& visit);

}  // namespace novelty_detection
