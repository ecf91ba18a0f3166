#include "novelty_detection/mixture/novelty_selection.h"

#include <algorithm>
#include <limits>
#include <numeric>
#include <stdexcept>

#include "common/parallel.h"

namespace novelty_detection {

GreedyNoveltySelector::GreedyNoveltySelector(const SelectionParams& params) : params_(params) {
  params_.validate();
}

SelectionResult GreedyNoveltySelector::select(const Gmm& current, const Gmm& reference,
                                              double u_th) const {
  Eigen::VectorXd p(current.size()), q(reference.size());
  for (std::size_t i = 0; i < current.size(); ++i) p[i] = current.components[i].weight;
  for (std::size_t j = 0; j < reference.size(); ++j) q[j] = reference.components[j].weight;
  return select(
      p, q, groundDistanceMatrix(current, reference, parseGroundDistance(params_.ground_distance)),
      u_th);
}

SelectionResult GreedyNoveltySelector::select(const Eigen::VectorXd& p_in, const Eigen::VectorXd& q,
                                              const Eigen::MatrixXd& d, double u_th) const {
  if (u_th < 0) u_th = params_.u_th;
  SelectionResult out;
  const Eigen::Index n = p_in.size();
  // One solver per lane of the candidates' solves (a solver keeps its network); the first
  // also solves the full problems. It validates sizes and values on its first solve.
  const int lanes = std::max(1, threads_);
  std::vector<EmdSolver> solvers;
  solvers.reserve(static_cast<std::size_t>(lanes));
  for (int k = 0; k < lanes; ++k) solvers.emplace_back(d);
  const EmdSolver& solver = solvers.front();
  std::vector<Eigen::VectorXd> lane_p(static_cast<std::size_t>(lanes));
  Eigen::VectorXd p = p_in;
  EmdResult full = solver.solve(p, q, true);
  out.emd_before = full.distance;
  out.emd_trace.push_back(full.distance);
  if (n == 0 || q.size() == 0) {
    out.emd_after = out.emd_before;
    return out;
  }
  const Eigen::VectorXd nearest = d.rowwise().minCoeff();  // min_j d_ij
  const double q_mass = q.sum();
  double current = full.distance;

  while (static_cast<int>(out.novel.size()) < params_.max_novel_gaussians) {
    if (!(current > u_th)) break;
    const double mass = p.sum();
    const double near_cost = p.dot(nearest);
    const Eigen::VectorXd row_cost = (full.flows.cwiseProduct(d)).rowwise().sum();
    // Dual solutions of this round's problems (capacity prices beta, EmdResult, with alpha_i =
    // min_j (d_ij + beta_j)): dual feasibility does not depend on the supplies, so each bounds
    // every removal from below by weak duality, (sum_k p_k alpha_k - q.beta - p_i alpha_i) /
    // rest, tight where i's flow went to unfilled capacity. The full solve's first, then
    // every solved candidate's.
    struct Dual {
      Eigen::VectorXd alpha;
      double total;
    };
    std::vector<Dual> duals;
    auto addDual = [&](const Eigen::VectorXd& beta) {
      if (beta.size() != q.size()) return;  // solved transposed: no prices
      Dual dual;
      dual.alpha = (d.rowwise() + beta.transpose()).rowwise().minCoeff();
      dual.total = p.dot(dual.alpha) - q.dot(beta);
      duals.push_back(std::move(dual));
    };
    addDual(full.capacity_prices);
    struct Candidate {
      Eigen::Index i;
      double ub, lb;
    };
    std::vector<Candidate> cands;
    for (Eigen::Index i = 0; i < n; ++i) {
      if (!(p[i] > 0)) continue;
      const double rest = mass - p[i];
      Candidate c{i, 0.0, 0.0};
      if (rest > 0) {
        c.ub = std::max(0.0, full.cost - row_cost[i]) / rest;
        // The lower bound holds while the remaining Theta is the lighter side.
        c.lb = rest <= q_mass ? std::max(0.0, near_cost - p[i] * nearest[i]) / rest : 0.0;
      }
      cands.push_back(c);
    }
    if (cands.empty()) break;
    std::stable_sort(cands.begin(), cands.end(),
                     [](const Candidate& a, const Candidate& b) { return a.ub < b.ub; });
    // Candidates in order of their upper bounds, up to one per thread at a time, each solved
    // unless its lower bound exceeds the best value before its batch; the batch's values are
    // then taken in order. A candidate solved only because of the batching has a value
    // above the best by more than the ties' tolerance, so the choice is the serial one.
    double best = std::numeric_limits<double>::infinity();
    Eigen::Index best_i = -1;
    auto lowerBound = [&](const Candidate& c) {
      double lb = c.lb;
      const double rest = mass - p[c.i];
      if (!(rest > 0) || rest > q_mass) return lb;
      for (const Dual& dual : duals) {
        // Round-off margin: the bound only skips solves, it must never exceed the value.
        const double v = (dual.total - p[c.i] * dual.alpha[c.i]) / rest;
        lb = std::max(lb, v - 1e-9 * std::abs(v));
      }
      return lb;
    };
    // Each lane's weights: this round's, the candidate's emptied while it is solved.
    for (Eigen::VectorXd& w : lane_p) w = p;
    std::vector<const Candidate*> batch;
    std::vector<EmdResult> results;
    for (std::size_t next = 0; next < cands.size();) {
      batch.clear();
      while (next < cands.size() && static_cast<int>(batch.size()) < lanes) {
        const Candidate& c = cands[next++];
        if (best_i >= 0 && lowerBound(c) > best * (1.0 + 1e-9) + 1e-15) continue;
        batch.push_back(&c);
      }
      results.assign(batch.size(), EmdResult());  // an emptied Theta has nothing left to move
      detail::parallelFor(static_cast<int>(batch.size()), lanes, [&](int k) {
        const Eigen::Index i = batch[static_cast<std::size_t>(k)]->i;
        if (!(mass - p[i] > 0)) return;
        Eigen::VectorXd& w = lane_p[static_cast<std::size_t>(k)];
        w[i] = 0.0;
        results[static_cast<std::size_t>(k)] =
            solvers[static_cast<std::size_t>(k)].solveWithPrices(w, q);
        w[i] = p[i];
      });
      for (std::size_t k = 0; k < batch.size(); ++k) {
        const Eigen::Index i = batch[k]->i;
        if (mass - p[i] > 0) ++out.exact_evaluations;
        const double value = results[k].distance;
        addDual(results[k].capacity_prices);
        const double tol = best_i < 0 ? 0.0 : 1e-12 * std::max(1.0, best);
        if (best_i < 0 || value < best - tol || (value <= best + tol && i < best_i)) {
          best = value;
          best_i = i;
        }
      }
    }
    const double decrease = current - best;
    if (!(decrease >= params_.min_relative_decrease * current) || !(decrease > 0)) break;
    p[best_i] = 0.0;
    out.novel.push_back(static_cast<int>(best_i));
    out.decrease.push_back(decrease);
    out.emd_trace.push_back(best);
    current = best;
    full = solver.solve(p, q, true);
  }
  out.emd_after = current;
  return out;
}

}  // namespace novelty_detection
