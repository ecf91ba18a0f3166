#include "novelty_detection/mixture/emd.h"

#include "mixture/transport_simplex.h"

#include <lemon/network_simplex.h>
#include <lemon/smart_graph.h>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace novelty_detection {
namespace {

Eigen::Matrix3d sqrtPsd(const Eigen::Matrix3d& s) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(0.5 * (s + s.transpose()));
  const Eigen::Vector3d ev = es.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  return es.eigenvectors() * ev.asDiagonal() * es.eigenvectors().transpose();
}

/// Bures term tr(Sa + Sb - 2 (Sb^1/2 Sa Sb^1/2)^1/2) given Sb^1/2, clamped at 0.
double buresSquared(const Eigen::Matrix3d& sa, const Eigen::Matrix3d& sb,
                    const Eigen::Matrix3d& sb_sqrt) {
  const Eigen::Matrix3d m = sb_sqrt * sa * sb_sqrt;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(0.5 * (m + m.transpose()), Eigen::EigenvaluesOnly);
  const double cross = es.eigenvalues().cwiseMax(0.0).cwiseSqrt().sum();
  const double v = sa.trace() + sb.trace() - 2.0 * cross;
  // Round-off of the eigen-decompositions: identical covariances must give exactly 0.
  return v > 1e-12 * (sa.trace() + sb.trace()) ? v : 0.0;
}

void checkWeights(const Eigen::VectorXd& w, Eigen::Index expected, const char* name) {
  if (w.size() != expected) {
    throw std::invalid_argument(std::string("EMD: ") + name + " has " + std::to_string(w.size()) +
                                " weights, expected " + std::to_string(expected));
  }
  if (!w.allFinite() || (w.array() < 0.0).any()) {
    throw std::invalid_argument(std::string("EMD: ") + name +
                                " has a negative or non-finite weight");
  }
}

}  // namespace

GroundDistance parseGroundDistance(const std::string& name) {
  if (name == "euclidean") return GroundDistance::kEuclidean;
  if (name == "wasserstein") return GroundDistance::kWasserstein;
  throw std::invalid_argument("unknown ground distance '" + name +
                              "' (expected 'wasserstein' or 'euclidean')");
}

double gaussianDistance(const Gaussian& a, const Gaussian& b, GroundDistance type) {
  const double m2 = (a.mean - b.mean).squaredNorm();
  if (type == GroundDistance::kEuclidean) return std::sqrt(m2);
  return std::sqrt(m2 + buresSquared(a.cov, b.cov, sqrtPsd(b.cov)));
}

Eigen::MatrixXd groundDistanceMatrix(const Gmm& a, const Gmm& b, GroundDistance type) {
  const Eigen::Index n = static_cast<Eigen::Index>(a.size());
  const Eigen::Index m = static_cast<Eigen::Index>(b.size());
  Eigen::MatrixXd d(n, m);
  std::vector<Eigen::Matrix3d> b_sqrt;
  if (type == GroundDistance::kWasserstein) {
    b_sqrt.reserve(m);
    for (const auto& g : b.components) b_sqrt.push_back(sqrtPsd(g.cov));
  }
  for (Eigen::Index j = 0; j < m; ++j) {
    const Gaussian& gb = b.components[j];
    for (Eigen::Index i = 0; i < n; ++i) {
      const Gaussian& ga = a.components[i];
      double v = (ga.mean - gb.mean).squaredNorm();
      if (type == GroundDistance::kWasserstein) v += buresSquared(ga.cov, gb.cov, b_sqrt[j]);
      d(i, j) = std::sqrt(v);
    }
  }
  return d;
}

struct EmdBasis {
  bool transposed = false;  ///< solved with the second mixture supplying
  detail::TransportBasis basis;
};

/// LEMON's network simplex, for the solves the dual simplex gives up (transport_simplex.h).
struct EmdSolver::Network {
  using Graph = lemon::SmartDigraph;
  using Simplex = lemon::NetworkSimplex<Graph, double, double>;
  Graph graph;
  Graph::ArcMap<double> cost{graph};
  Graph::NodeMap<double> supply{graph};
  std::vector<Graph::Node> sources, sinks;
  std::vector<Graph::Arc> arcs;  // row-major over (source, sink)
  std::unique_ptr<Simplex> simplex;

  // d: sources x sinks cost matrix.
  explicit Network(const Eigen::MatrixXd& d) {
    const Eigen::Index n = d.rows(), m = d.cols();
    graph.reserveNode(static_cast<int>(n + m));
    graph.reserveArc(static_cast<int>(n * m));
    for (Eigen::Index i = 0; i < n; ++i) sources.push_back(graph.addNode());
    for (Eigen::Index j = 0; j < m; ++j) sinks.push_back(graph.addNode());
    for (Eigen::Index i = 0; i < n; ++i) {
      for (Eigen::Index j = 0; j < m; ++j) {
        const auto a = graph.addArc(sources[i], sinks[j]);
        cost[a] = d(i, j);
        arcs.push_back(a);
      }
    }
    simplex = std::make_unique<Simplex>(graph);
    simplex->costMap(cost);
    simplex->supplyType(Simplex::GEQ);
  }

  /// `s` supplies all of its mass; sink j accepts at most accept[j] (EmdSolver::solve()'s
  /// capacities, a hair above the weights).
  EmdResult solve(const Eigen::VectorXd& s, const Eigen::VectorXd& accept, bool with_flows,
                  bool with_prices, bool transpose) {
    const double ss = s.sum();
    for (std::size_t i = 0; i < sources.size(); ++i) supply[sources[i]] = s[i];
    for (std::size_t j = 0; j < sinks.size(); ++j) supply[sinks[j]] = -accept[j];
    simplex->supplyMap(supply);
    if (simplex->run() != Simplex::OPTIMAL) {
      throw std::runtime_error("EMD: the transportation problem has no optimal solution");
    }
    EmdResult r;
    r.cost = simplex->totalCost<double>();
    r.flow = ss;
    r.distance = ss > 0 ? r.cost / ss : 0.0;
    if (with_flows) {
      const Eigen::Index n = static_cast<Eigen::Index>(sources.size());
      const Eigen::Index m = static_cast<Eigen::Index>(sinks.size());
      r.flows.resize(transpose ? m : n, transpose ? n : m);
      for (Eigen::Index i = 0; i < n; ++i) {
        for (Eigen::Index j = 0; j < m; ++j) {
          const double f = simplex->flow(arcs[i * m + j]);
          if (transpose) {
            r.flows(j, i) = f;
          } else {
            r.flows(i, j) = f;
          }
        }
      }
    }
    if ((with_flows || with_prices) && !transpose) {
      // LEMON's potentials: reduced costs d_ij + pi_i - pi_j >= 0, pi <= 0 (GEQ form).
      r.capacity_prices.resize(static_cast<Eigen::Index>(sinks.size()));
      for (std::size_t j = 0; j < sinks.size(); ++j)
        r.capacity_prices[static_cast<Eigen::Index>(j)] =
            std::max(0.0, -simplex->potential(sinks[j]));
    }
    return r;
  }
};

EmdSolver::EmdSolver(const Eigen::MatrixXd& ground_distance) : d_(ground_distance) {
  if (!d_.allFinite() || (d_.array() < 0.0).any()) {
    throw std::invalid_argument("EMD: ground distances must be finite and non-negative");
  }
}
EmdSolver::~EmdSolver() = default;
EmdSolver::EmdSolver(EmdSolver&&) noexcept = default;
EmdSolver& EmdSolver::operator=(EmdSolver&&) noexcept = default;

EmdResult EmdSolver::solve(const Eigen::VectorXd& p, const Eigen::VectorXd& q, bool with_flows,
                           const EmdResult* from) const {
  return solve(p, q, with_flows, false, from);
}

EmdResult EmdSolver::solveWithPrices(const Eigen::VectorXd& p, const Eigen::VectorXd& q,
                                     const EmdResult* from) const {
  return solve(p, q, false, true, from);
}

EmdResult EmdSolver::solve(const Eigen::VectorXd& p, const Eigen::VectorXd& q, bool with_flows,
                           bool with_prices, const EmdResult* from) const {
  checkWeights(p, d_.rows(), "first mixture");
  checkWeights(q, d_.cols(), "second mixture");
  EmdResult r;
  const double ps = p.sum(), qs = q.sum();
  if (!(ps > 0) || !(qs > 0)) {
    if (with_flows) r.flows = Eigen::MatrixXd::Zero(d_.rows(), d_.cols());
    return r;  // nothing can move: distance 0 by convention
  }
  // The lighter side supplies; the other accepts a hair more than its weights, so that
  // round-off never makes equal masses infeasible.
  const bool transpose = !(ps <= qs);
  const Eigen::VectorXd& s = transpose ? q : p;
  const Eigen::VectorXd& t = transpose ? p : q;
  const double ss = s.sum(), ts = t.sum(), slack = 1.0 + 1e-12;
  Eigen::VectorXd accept = t * slack;
  // Only reachable through round-off when the caller passed nearly equal masses.
  if (ss > ts * slack) accept *= ss / (ts * slack) * (1.0 + 1e-12);
  if (transpose && d_transposed_.size() == 0) d_transposed_ = d_.transpose();
  const detail::TransportBasis* start =
      from && from->basis && from->basis->transposed == transpose ? &from->basis->basis : nullptr;
  detail::TransportSolution solution =
      detail::solveTransport(transpose ? d_transposed_ : d_, s, accept, start, with_flows);
  if (!solution.optimal) {
    std::unique_ptr<Network>& network = transpose ? backward_ : forward_;
    if (!network) network = std::make_unique<Network>(transpose ? d_transposed_ : d_);
    return network->solve(s, accept, with_flows, with_prices, transpose);
  }
  r.cost = solution.cost;
  r.flow = ss;
  r.distance = r.cost / ss;
  if (with_flows) {
    if (transpose) {
      r.flows = solution.flows.transpose();
    } else {
      r.flows = std::move(solution.flows);
    }
  }
  if ((with_flows || with_prices) && !transpose) r.capacity_prices = std::move(solution.prices);
  auto basis = std::make_shared<EmdBasis>();
  basis->transposed = transpose;
  basis->basis = std::move(solution.basis);
  r.basis = std::move(basis);
  return r;
}

double emd(const Gmm& a, const Gmm& b, GroundDistance type) {
  Eigen::VectorXd p(a.size()), q(b.size());
  for (std::size_t i = 0; i < a.size(); ++i) p[i] = a.components[i].weight;
  for (std::size_t j = 0; j < b.size(); ++j) q[j] = b.components[j].weight;
  return EmdSolver(groundDistanceMatrix(a, b, type)).solve(p, q).distance;
}

}  // namespace novelty_detection
