// Greedy novelty selection (paper Sec. IV-D, Algorithm 1). ROS-free.
//
// Theta = current mixture (weights p), Gamma = reference mixture (weights q), Pi = novel set.
// d_0 = EMD(Theta, Gamma). Round t = 1, 2, ...:
//   for every Gaussian i still in Theta (the last one included), d_i = EMD(Theta \ {i}, Gamma)
//   with Rubner's partial matching (Theta keeps its weights; its mass shrinks below Gamma's);
//   i* = argmin d_i (ties: lowest index).
//   Stop rule (the paper's line 6 is loosely written; this is the rule implemented):
//     accept i* iff  d_{t-1} > u_th                                   (still a novelty)
//                and d_{t-1} - d_{i*} >= min_relative_decrease * d_{t-1}  (it helps enough)
//                and |Pi| < max_novel_gaussians;
//   on acceptance move i* from Theta to Pi, d_t = d_{i*}; otherwise stop, Theta unchanged.
//   An empty Theta has EMD 0 by convention (nothing left to move).
// Speed: the ground-distance matrix is computed once and the flow network is built once;
// a removal only zeroes a supply. Candidates are ranked by an upper bound from the current
// optimal flow (drop row i: UB_i = (C - c_i) / (m - p_i), a feasible flow of the smaller
// problem) and pruned by a lower bound (every remaining unit of Theta travels at least to
// its nearest Gamma: LB_i = sum_{k != i} p_k min_j d_kj / (m - p_i)) and by the dual
// solutions at hand (the current optimum's, then each solved candidate's: dual feasibility
// does not depend on the supplies, so each bounds every other removal by weak duality); only
// candidates whose LB beats the best exact value found so far are solved exactly. The result
// is the same as evaluating every candidate.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "novelty_detection/mixture/emd.h"
#include "novelty_detection/params.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

struct SelectionResult {
  std::vector<int> novel;         ///< indices into the current mixture, in selection order
  std::vector<double> decrease;   ///< EMD decrease owed to each selected Gaussian
  std::vector<double> emd_trace;  ///< d_0, d_1, ... after each accepted removal
  double emd_before = 0.0;
  double emd_after = 0.0;
  int exact_evaluations = 0;  ///< EMD solves spent on candidates (for benchmarks)
};

class GreedyNoveltySelector {
 public:
  explicit GreedyNoveltySelector(const SelectionParams& params);

  /// Selection between two mixtures with the configured ground distance; `u_th` overrides
  /// params.u_th when >= 0 (the pipeline derives it from the data's noise).
  SelectionResult select(const Gmm& current, const Gmm& reference, double u_th = -1.0) const;

  /// Candidates' EMD solves on up to this many threads (compute/threads); the result does
  /// not depend on it.
  GreedyNoveltySelector& setThreads(int threads) {
    threads_ = threads;
    return *this;
  }

  /// Same on raw weights and a precomputed ground-distance matrix (n x m).
  SelectionResult select(const Eigen::VectorXd& p, const Eigen::VectorXd& q,
                         const Eigen::MatrixXd& ground_distance, double u_th = -1.0) const;

 private:
  SelectionParams params_;
  int threads_ = 1;
};

}  // namespace novelty_detection
