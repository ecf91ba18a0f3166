// The transportation problem behind the EMD, solved by the dual network simplex: private to
// the core (emd.cpp).
//
// Problem: sources i < n ship exactly s_i, sinks j < m accept at most t_j (sum s <= sum t),
// at cost c_ij per unit; minimise the total cost. A slack source n ships the spare capacity
// sum t - sum s at cost 0, which makes every sink accept exactly t_j. A basis is a spanning
// tree of n + m of the (source, sink) arcs; its flows follow from the supplies, its
// potentials u_i + v_j = c_ij from the costs (u_n = 0).
//
// Dual simplex (e.g. Ahuja, Magnanti & Orlin, Network Flows, 1993, Sec. 11.6): a basis whose
// reduced costs c_ij - u_i - v_j are all >= 0 (dual feasible) is optimal once its flows are
// >= 0. While one is negative, that tree arc leaves: removing it parts the tree into the side
// K of its source and the side L of its sink; the arc from a source in L to a sink in K of
// least reduced cost enters, which keeps every reduced cost >= 0. Changing the supplies
// keeps a basis dual feasible, so an optimal basis is a warm start for other weights: the
// problems of the EMD selection differ by one source's weight, and are solved from the
// optimum of the round they belong to in a few pivots.
// Cold start: the slack source to every sink and each source to its cheapest sink (u_i the
// row minimum, v = 0): dual feasible.
#pragma once

#include <Eigen/Core>

#include <utility>
#include <vector>

namespace novelty_detection {
namespace detail {

/// A basis: its n + m tree arcs as (source, sink); source n is the slack source.
struct TransportBasis {
  int n = 0, m = 0;
  std::vector<std::pair<int, int>> arcs;
};

struct TransportSolution {
  bool optimal = false;    ///< false: no optimum within the pivot cap (the caller falls back)
  double cost = 0.0;       ///< sum c_ij x_ij over the real sources
  Eigen::MatrixXd flows;   ///< x_ij (n x m), when asked for
  Eigen::VectorXd prices;  ///< -v_j >= 0 per sink: the price of its capacity (u_n = 0)
  TransportBasis basis;    ///< the optimal basis
  int pivots = 0;
};

/// Solves the problem above for costs c (n x m), supplies s (n) and capacities t (m), with
/// sum s <= sum t, from `start` (a basis of the same sizes) or, without one, cold.
TransportSolution solveTransport(const Eigen::MatrixXd& c, const Eigen::VectorXd& s,
                                 const Eigen::VectorXd& t, const TransportBasis* start,
                                 bool with_flows);

}  // namespace detail
}  // namespace novelty_detection
