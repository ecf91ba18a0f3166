#include "novelty_detection/mixture/novelty_selection.h"

#include <algorithm>
#include <atomic>
#include <cmath>
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
    auto dualOf = [&](const Eigen::VectorXd& beta) {
      Dual dual;
      dual.alpha = (d.rowwise() + beta.transpose()).rowwise().minCoeff();
      dual.total = p.dot(dual.alpha) - q.dot(beta);
      return dual;
    };
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
    auto lowerBound = [&](const Candidate& c, const std::vector<Dual>& known) {
      double lb = c.lb;
      const double rest = mass - p[c.i];
      if (!(rest > 0) || rest > q_mass) return lb;
      for (const Dual& dual : known) {
        // Round-off margin: the bound only skips solves, it must never exceed the value.
        const double v = (dual.total - p[c.i] * dual.alpha[c.i]) / rest;
        lb = std::max(lb, v - 1e-9 * std::abs(v));
      }
      return lb;
    };
    // Each lane's weights: this round's, the candidate's emptied while it is solved.
    for (Eigen::VectorXd& w : lane_p) w = p;
    // Candidates in order of their upper bounds, dealt to the lanes in turn (lane k takes
    // the k-th, (k + lanes)-th, ...); each is solved unless its lower bound, from the prices
    // of the full solve and of the lane's own solves, exceeds the best value any lane has
    // found. That value is never below the round's minimum, so a candidate skipped has a
    // value above the minimum by more than the ties' tolerance; the values found are then
    // compared in the serial order, and the choice is the serial one for any lane count.
    std::vector<double> value(cands.size(), std::numeric_limits<double>::quiet_NaN());
    std::atomic<double> shared_best{std::numeric_limits<double>::infinity()};
    std::vector<int> solved(static_cast<std::size_t>(lanes), 0);
    std::vector<Dual> full_dual;  // none when solved transposed
    if (full.capacity_prices.size() == q.size()) full_dual.push_back(dualOf(full.capacity_prices));
    detail::parallelFor(lanes, lanes, [&](int lane) {
      std::vector<Dual> known = full_dual;
      Eigen::VectorXd& w = lane_p[static_cast<std::size_t>(lane)];
      const EmdSolver& lane_solver = solvers[static_cast<std::size_t>(lane)];
      for (std::size_t c = static_cast<std::size_t>(lane); c < cands.size();
           c += static_cast<std::size_t>(lanes)) {
        const Candidate& cand = cands[c];
        const double best = shared_best.load(std::memory_order_relaxed);
        if (std::isfinite(best) && lowerBound(cand, known) > best * (1.0 + 1e-9) + 1e-15) continue;
        const Eigen::Index i = cand.i;
        EmdResult result;  // an emptied Theta has nothing left to move
        if (mass - p[i] > 0) {
          w[i] = 0.0;
          result = lane_solver.solveWithPrices(w, q, &full);
          w[i] = p[i];
          ++solved[static_cast<std::size_t>(lane)];
          if (result.capacity_prices.size() == q.size())
            known.push_back(dualOf(result.capacity_prices));
        }
        value[c] = result.distance;
        double seen = shared_best.load(std::memory_order_relaxed);
        while (result.distance < seen && !shared_best.compare_exchange_weak(
                                             seen, result.distance, std::memory_order_relaxed)) {
        }
      }
    });
    for (int count : solved) out.exact_evaluations += count;
    double best = std::numeric_limits<double>::infinity();
    Eigen::Index best_i = -1;
    for (std::size_t c = 0; c < cands.size(); ++c) {
      if (std::isnan(value[c])) continue;  // skipped: above the minimum
      const Eigen::Index i = cands[c].i;
      const double tol = best_i < 0 ? 0.0 : 1e-12 * std::max(1.0, best);
      if (best_i < 0 || value[c] < best - tol || (value[c] <= best + tol && i < best_i)) {
        best = value[c];
        best_i = i;
      }
    }
    const double decrease = current - best;
    if (!(decrease >= params_.min_relative_decrease * current) || !(decrease > 0)) break;
    p[best_i] = 0.0;
    out.novel.push_back(static_cast<int>(best_i));
    out.decrease.push_back(decrease);
    out.emd_trace.push_back(best);
    current = best;
    full = solver.solve(p, q, true, &full);
  }
  out.emd_after = current;
  return out;
}

}  // namespace novelty_detection
