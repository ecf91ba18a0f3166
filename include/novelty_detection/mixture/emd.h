// Earth Mover's Distance between Gaussian mixtures (paper eq. 1, Rubner et al. 2000).
// ROS-free; LEMON stays inside emd.cpp.
//
// EMD(P, Q) = min_f sum_ij f_ij d_ij / sum_ij f_ij subject to f_ij >= 0,
// sum_j f_ij <= p_i, sum_i f_ij <= q_j, sum_ij f_ij = min(sum p, sum q).
// With unequal total masses this is Rubner's partial matching: the lighter side is moved
// entirely, the heavier one only in part, and the cost is normalised by the moved flow.
// Solved exactly as a transportation problem (the lighter side supplies exactly its mass, the
// heavier side's nodes accept at most theirs) by a dual network simplex that can start from
// the optimal basis of other weights; LEMON's NetworkSimplex where that does not converge.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>

#include "novelty_detection/types.h"

namespace novelty_detection {

/// Ground distance between two Gaussians.
enum class GroundDistance {
  kEuclidean,    ///< |mu_a - mu_b|
  kWasserstein,  ///< 2-Wasserstein: sqrt(|mu_a-mu_b|^2 + tr(Sa + Sb - 2 (Sb^1/2 Sa Sb^1/2)^1/2))
};

/// "euclidean" or "wasserstein"; throws std::invalid_argument otherwise.
GroundDistance parseGroundDistance(const std::string& name);

double gaussianDistance(const Gaussian& a, const Gaussian& b, GroundDistance type);

/// D(i, j) = gaussianDistance(a_i, b_j); matrix square roots computed once per Gaussian.
Eigen::MatrixXd groundDistanceMatrix(const Gmm& a, const Gmm& b, GroundDistance type);

/// An optimal basis of a solve (opaque): a warm start for solves of other weights.
struct EmdBasis;

struct EmdResult {
  double distance = 0.0;  ///< cost / flow (0 when nothing moves)
  double cost = 0.0;      ///< sum f_ij d_ij
  double flow = 0.0;      ///< sum f_ij = min(sum p, sum q)
  Eigen::MatrixXd flows;  ///< f_ij, filled when requested
  /// With the flows or the prices, when the first mixture is the lighter side (it ships all its
  /// mass and the second's weights are capacities): the optimal dual's price beta_j >= 0 of each of
  /// the second's capacities (empty otherwise). For any weights p' of the first, with
  /// alpha_i = min_j (d_ij + beta_j), sum_i p'_i alpha_i - sum_j q_j beta_j is a lower bound
  /// on the cost of moving p' (weak duality); it equals the cost for the p solved.
  Eigen::VectorXd capacity_prices;
  /// The optimal basis, for EmdSolver::solve(..., from) (empty when LEMON solved it).
  std::shared_ptr<const EmdBasis> basis;
};

/// Repeated EMD solves over one ground-distance matrix (n x m): masking a Gaussian = giving it
/// weight 0. A solve started `from` the result of nearby weights (one Gaussian masked, say)
/// needs only the few pivots that tell them apart; the result is the same optimum.
class EmdSolver {
 public:
  explicit EmdSolver(const Eigen::MatrixXd& ground_distance);
  ~EmdSolver();
  EmdSolver(EmdSolver&&) noexcept;
  EmdSolver& operator=(EmdSolver&&) noexcept;

  /// p: n weights, q: m weights (non-negative). Throws std::invalid_argument on bad sizes,
  /// negative or non-finite weights.
  EmdResult solve(const Eigen::VectorXd& p, const Eigen::VectorXd& q, bool with_flows = false,
                  const EmdResult* from = nullptr) const;
  /// solve() with the capacity prices but not the flows.
  EmdResult solveWithPrices(const Eigen::VectorXd& p, const Eigen::VectorXd& q,
                            const EmdResult* from = nullptr) const;

  const Eigen::MatrixXd& groundDistance() const { return d_; }

 private:
  EmdResult solve(const Eigen::VectorXd& p, const Eigen::VectorXd& q, bool with_flows,
                  bool with_prices, const EmdResult* from) const;
  struct Network;
  Eigen::MatrixXd d_;
  mutable Eigen::MatrixXd d_transposed_;       // for q supplying (made on first use)
  mutable std::unique_ptr<Network> forward_;   // LEMON: p supplies, q accepts
  mutable std::unique_ptr<Network> backward_;  // LEMON: q supplies, p accepts
};

/// EMD between two mixtures with the given ground distance (their weights as masses).
double emd(const Gmm& a, const Gmm& b, GroundDistance type = GroundDistance::kWasserstein);

}  // namespace novelty_detection
