#include "novelty_detection/mixture/gmm.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <stdexcept>

#include "common/parallel.h"

namespace novelty_detection {
namespace {

constexpr double kLog2Pi = 1.8378770664093453;

/// Points per block of an E-step: blocks are fixed, whatever the thread count, so that
/// every entry is computed the same way.
constexpr Eigen::Index kPointBlock = 1024;

/// Number of kPointBlock blocks over n points.
int pointBlocks(Eigen::Index n) { return static_cast<int>((n + kPointBlock - 1) / kPointBlock); }

/// Threads for an E-step over n points: one below four blocks, where handing blocks to
/// another thread (once per EM iteration) costs about what it saves.
int stepThreads(Eigen::Index n, int threads) { return n >= 4 * kPointBlock ? threads : 1; }

void checkData(const WeightedPoints& data) {
  if (data.weights.size() && data.weights.size() != data.points.cols()) {
    throw std::invalid_argument("GMM: weights size does not match the number of points");
  }
  if (data.covariances.cols() && data.covariances.cols() != data.points.cols()) {
    throw std::invalid_argument("GMM: covariances size does not match the number of points");
  }
  if (!data.points.allFinite()) throw std::invalid_argument("GMM: non-finite point");
  if (data.weights.size() && (data.weights.array() < 0.0).any()) {
    throw std::invalid_argument("GMM: negative point weight");
  }
}

Eigen::VectorXd weightVector(const WeightedPoints& data) {
  return data.weights.size() ? data.weights : Eigen::VectorXd::Ones(data.points.cols());
}

/// Below this log-ratio to a column's largest entry a term is taken as 0: exp(-50) = 2e-22,
/// under the rounding of a sum that holds 1, even with a thousand such terms.
constexpr double kNegligibleLogRatio = -50.0;

/// In place: a column of K log-values becomes its softmax; returns its log-sum-exp. A point
/// is near a few of the K Gaussians: only the entries within kNegligibleLogRatio of the
/// column's largest cost an exp (the hot loop of EM), the rest are exactly 0. A column of
/// -inf (every weight zero) becomes uniform with lse -inf.
double softmaxColumn(double* col, Eigen::Index rows) {
  double m = -std::numeric_limits<double>::infinity();
  for (Eigen::Index k = 0; k < rows; ++k) m = std::max(m, col[k]);
  if (!std::isfinite(m)) {
    std::fill(col, col + rows, 1.0 / static_cast<double>(std::max<Eigen::Index>(1, rows)));
    return m;
  }
  double sum = 0.0;
  for (Eigen::Index k = 0; k < rows; ++k) {
    const double v = col[k] - m;
    col[k] = v < kNegligibleLogRatio ? 0.0 : std::exp(v);
    sum += col[k];
  }
  const double inv = 1.0 / sum;
  for (Eigen::Index k = 0; k < rows; ++k) col[k] *= inv;
  return m + std::log(sum);
}

/// softmaxColumn() on each column of a (K x N), lse[n] receiving column n's. Columns are
/// independent: blocks of them run on up to `threads` threads.
void softmaxCols(Eigen::MatrixXd& a, Eigen::VectorXd& lse, int threads) {
  lse.resize(a.cols());
  const Eigen::Index rows = a.rows();
  detail::parallelFor(pointBlocks(a.cols()), stepThreads(a.cols(), threads), [&](int b) {
    const Eigen::Index end = std::min(a.cols(), (b + 1) * kPointBlock);
    for (Eigen::Index n = b * kPointBlock; n < end; ++n)
      lse[n] = softmaxColumn(a.col(n).data(), rows);
  });
}

/// One M-step from responsibilities R (K x N). Returns the new mixture (empty comps dropped).
Gmm mStep(const WeightedPoints& data, const Eigen::VectorXd& w, const Eigen::MatrixXd& resp,
          double ridge) {
  const double total = w.sum();
  Gmm out;
  const Eigen::MatrixXd wr = resp.array().rowwise() * w.transpose().array();  // K x N
  const Eigen::VectorXd nk = wr.rowwise().sum();
  for (Eigen::Index k = 0; k < resp.rows(); ++k) {
    if (!(nk[k] > 1e-9 * total)) continue;
    Gaussian g;
    g.weight = nk[k] / total;
    g.mean = data.points * wr.row(k).transpose() / nk[k];
    const Eigen::Matrix3Xd d = data.points.colwise() - g.mean;
    g.cov = (d * wr.row(k).asDiagonal() * d.transpose()) / nk[k];
    if (data.covariances.cols()) {
      const Eigen::Matrix<double, 9, 1> c = data.covariances * wr.row(k).transpose() / nk[k];
      g.cov += Eigen::Map<const Eigen::Matrix3d>(c.data());
    }
    g.cov = 0.5 * (g.cov + g.cov.transpose()).eval();
    g.cov.diagonal().array() += ridge;
    out.components.push_back(g);
  }
  double s = 0.0;
  for (const auto& g : out.components) s += g.weight;
  for (auto& g : out.components) g.weight /= s;
  return out;
}

}  // namespace

double WeightedPoints::totalWeight() const {
  return weights.size() ? weights.sum() : static_cast<double>(points.cols());
}

namespace {

/// Per Gaussian, in arrays over the Gaussians: the Cholesky factor L of its covariance as
/// forward substitution uses it (the diagonal as reciprocals), its mean, and log(pi) -
/// log|2 pi Sigma| / 2.
enum { kR00, kL10, kR11, kL20, kL21, kR22, kMx, kMy, kMz, kOffset, kFields };
using PackedGaussians = Eigen::Matrix<double, Eigen::Dynamic, kFields>;

PackedGaussians pack(const Gmm& gmm) {
  const Eigen::Index k_count = static_cast<Eigen::Index>(gmm.size());
  PackedGaussians g(k_count, static_cast<int>(kFields));
  for (Eigen::Index k = 0; k < k_count; ++k) {
    const Gaussian& c = gmm.components[k];
    Eigen::LLT<Eigen::Matrix3d> llt(c.cov);
    Eigen::Matrix3d cov = c.cov;
    if (llt.info() != Eigen::Success) {
      // Not positive definite (a hand-made mixture): lift it just enough.
      cov.diagonal().array() += 1e-9 + std::abs(cov.diagonal().minCoeff());
      llt.compute(cov);
    }
    const Eigen::Matrix3d l = llt.matrixL();
    const double log_det = 2.0 * l.diagonal().array().log().sum();
    g.row(k) << 1.0 / l(0, 0), l(1, 0), 1.0 / l(1, 1), l(2, 0), l(2, 1), 1.0 / l(2, 2), c.mean.x(),
        c.mean.y(), c.mean.z(),
        (c.weight > 0 ? std::log(c.weight) : -std::numeric_limits<double>::infinity()) -
            0.5 * (3.0 * kLog2Pi + log_det);
  }
  return g;
}

/// The K log weighted densities of the point (px, py, pz) into `column`: y = L^-1 (p - mean)
/// by forward substitution (the operations of Eigen's triangular solve, in its order, so the
/// values are the same), then the log density; all Gaussians of one point at a time, so the
/// column is written contiguously.
void logDensitiesAt(const PackedGaussians& g, double px, double py, double pz, double* column) {
  for (Eigen::Index k = 0; k < g.rows(); ++k) {
    const double dx = px - g(k, kMx), dy = py - g(k, kMy), dz = pz - g(k, kMz);
    const double y0 = dx * g(k, kR00);
    const double y1 = (dy - g(k, kL10) * y0) * g(k, kR11);
    const double y2 = (dz - g(k, kL20) * y0 - g(k, kL21) * y1) * g(k, kR22);
    column[k] = g(k, kOffset) - 0.5 * (y0 * y0 + y1 * y1 + y2 * y2);
  }
}

}  // namespace

Eigen::MatrixXd logWeightedDensities(const Gmm& gmm, const Eigen::Matrix3Xd& points, int threads) {
  const PackedGaussians g = pack(gmm);
  Eigen::MatrixXd out(g.rows(), points.cols());
  detail::parallelFor(pointBlocks(points.cols()), stepThreads(points.cols(), threads), [&](int b) {
    const Eigen::Index end = std::min(points.cols(), (b + 1) * kPointBlock);
    for (Eigen::Index i = b * kPointBlock; i < end; ++i)
      logDensitiesAt(g, points(0, i), points(1, i), points(2, i), out.col(i).data());
  });
  return out;
}

void forEachResponsibility(const Gmm& gmm, const Eigen::Matrix3Xd& points, int threads,
                           const std::function<void(Eigen::Index, const double*, double)>& visit) {
  const PackedGaussians g = pack(gmm);
  const Eigen::Index rows = g.rows();
  detail::parallelFor(pointBlocks(points.cols()), stepThreads(points.cols(), threads), [&](int b) {
    std::vector<double> column(static_cast<std::size_t>(rows));
    const Eigen::Index end = std::min(points.cols(), (b + 1) * kPointBlock);
    for (Eigen::Index i = b * kPointBlock; i < end; ++i) {
      logDensitiesAt(g, points(0, i), points(1, i), points(2, i), column.data());
      const double lse = softmaxColumn(column.data(), rows);
      visit(i, column.data(), lse);
    }
  });
}

Eigen::MatrixXd responsibilities(const Gmm& gmm, const Eigen::Matrix3Xd& points,
                                 Eigen::VectorXd* log_likelihood, int threads) {
  Eigen::MatrixXd lp = logWeightedDensities(gmm, points, threads);
  Eigen::VectorXd lse;
  softmaxCols(lp, lse, threads);
  if (log_likelihood) *log_likelihood = std::move(lse);
  return lp;
}

GmmFitter::GmmFitter(const GmmParams& params) : params_(params) { params_.validate(); }

int GmmFitter::numComponents(const WeightedPoints& data) const {
  const double total = data.totalWeight();
  Eigen::Index positive = data.size();
  if (data.weights.size()) positive = (data.weights.array() > 0.0).count();
  const double k = std::ceil(total / params_.points_per_component);
  int out = static_cast<int>(std::min<double>(k, params_.max_components));
  out = std::min<int>(out, static_cast<int>(positive));
  return std::max(out, positive > 0 ? 1 : 0);
}

std::vector<int> GmmFitter::kmeansLabels(const WeightedPoints& data, int k,
                                         int lloyd_iterations) const {
  const Eigen::Index n = data.size();
  std::vector<int> labels(n, 0);
  if (n == 0 || k <= 1) return labels;
  const Eigen::VectorXd w = weightVector(data);
  std::mt19937 rng(static_cast<unsigned>(params_.seed));
  // k-means++: the first centre drawn by weight, the next ones by weight * D^2.
  std::vector<Eigen::Vector3d> centres;
  Eigen::VectorXd d2 = Eigen::VectorXd::Constant(n, std::numeric_limits<double>::infinity());
  auto draw = [&](const Eigen::VectorXd& p) {
    const double s = p.sum();
    if (!(s > 0)) return Eigen::Index(-1);
    std::uniform_real_distribution<double> u(0.0, s);
    double t = u(rng), acc = 0.0;
    for (Eigen::Index i = 0; i < n; ++i) {
      acc += p[i];
      if (acc >= t && p[i] > 0) return i;
    }
    for (Eigen::Index i = n - 1; i >= 0; --i)
      if (p[i] > 0) return i;
    return Eigen::Index(-1);
  };
  Eigen::Index first = draw(w);
  if (first < 0) return labels;
  centres.push_back(data.points.col(first));
  // Greedy k-means++ (as in scikit-learn): of 2 + ln k candidates drawn by weight * D^2,
  // keep the one that lowers the weighted potential most; plain k-means++ too often puts
  // two centres in one cluster, a local optimum EM cannot leave.
  const int trials = 2 + static_cast<int>(std::log(static_cast<double>(k)));
  while (static_cast<int>(centres.size()) < k) {
    d2 = d2.cwiseMin((data.points.colwise() - centres.back()).colwise().squaredNorm().transpose());
    const Eigen::VectorXd prob = w.cwiseProduct(d2);
    Eigen::Index best = -1;
    double best_potential = std::numeric_limits<double>::infinity();
    for (int t = 0; t < trials; ++t) {
      const Eigen::Index cand = draw(prob);
      if (cand < 0) break;
      const double potential = w.dot(d2.cwiseMin(
          (data.points.colwise() - data.points.col(cand)).colwise().squaredNorm().transpose()));
      if (potential < best_potential) best_potential = potential, best = cand;
    }
    if (best < 0) break;  // every weighted point coincides with a centre
    centres.push_back(data.points.col(best));
  }
  const int kc = static_cast<int>(centres.size());
  Eigen::Matrix3Xd c(3, kc);
  for (int j = 0; j < kc; ++j) c.col(j) = centres[j];
  for (int it = 0; it <= lloyd_iterations; ++it) {
    // Assign: argmin_j |x - c_j|^2 = argmin_j (|c_j|^2 - 2 c_j . x).
    const Eigen::VectorXd cn = c.colwise().squaredNorm().transpose();
    const Eigen::MatrixXd score = (-2.0 * c.transpose() * data.points).colwise() + cn;
    for (Eigen::Index i = 0; i < n; ++i) score.col(i).minCoeff(&labels[i]);
    if (it == lloyd_iterations) break;
    Eigen::Matrix3Xd sum = Eigen::Matrix3Xd::Zero(3, kc);
    Eigen::VectorXd mass = Eigen::VectorXd::Zero(kc);
    for (Eigen::Index i = 0; i < n; ++i) {
      sum.col(labels[i]) += w[i] * data.points.col(i);
      mass[labels[i]] += w[i];
    }
    for (int j = 0; j < kc; ++j)
      if (mass[j] > 0) c.col(j) = sum.col(j) / mass[j];
  }
  return labels;
}

Gmm GmmFitter::initFromLabels(const WeightedPoints& data, const std::vector<int>& labels,
                              int k) const {
  checkData(data);
  if (static_cast<Eigen::Index>(labels.size()) != data.size()) {
    throw std::invalid_argument("GMM: labels size does not match the number of points");
  }
  Eigen::MatrixXd resp = Eigen::MatrixXd::Zero(k, data.size());
  for (Eigen::Index i = 0; i < data.size(); ++i) {
    if (labels[i] >= 0 && labels[i] < k) resp(labels[i], i) = 1.0;
  }
  const Eigen::VectorXd w = weightVector(data);
  return mStep(data, w, resp, params_.min_variance_m2);
}

Gmm GmmFitter::fit(const WeightedPoints& data, int k, EmStats* stats) const {
  checkData(data);
  if (k <= 0) k = numComponents(data);
  if (data.size() == 0 || k <= 0 || !(data.totalWeight() > 0)) {
    if (stats) *stats = EmStats{};
    return Gmm{};
  }
  const std::vector<int> labels = kmeansLabels(data, k);
  return fitFrom(data, initFromLabels(data, labels, k), stats);
}

Gmm GmmFitter::fitFrom(const WeightedPoints& data, const Gmm& init, EmStats* stats) const {
  checkData(data);
  EmStats st;
  const Eigen::VectorXd w = weightVector(data);
  const double total = w.sum();
  if (data.size() == 0 || init.empty() || !(total > 0)) {
    if (stats) *stats = st;
    return init;
  }
  Gmm gmm = init;
  double prev = -std::numeric_limits<double>::infinity();
  for (int it = 0; it < params_.max_iterations; ++it) {
    Eigen::VectorXd ll;
    const Eigen::MatrixXd resp = responsibilities(gmm, data.points, &ll, threads_);
    st.log_likelihood = w.dot(ll) / total;
    st.iterations = it + 1;
    if (st.log_likelihood - prev < params_.tolerance) {
      st.converged = true;
      break;
    }
    prev = st.log_likelihood;
    Gmm next = mStep(data, w, resp, params_.min_variance_m2);
    if (next.empty()) break;
    gmm = std::move(next);
  }
  if (stats) *stats = st;
  return gmm;
}

Gmm GmmFitter::fitWeights(const WeightedPoints& data, const Gmm& init, EmStats* stats) const {
  checkData(data);
  EmStats st;
  const Eigen::VectorXd w = weightVector(data);
  const double total = w.sum();
  Gmm gmm = init;
  if (data.size() == 0 || init.empty() || !(total > 0)) {
    if (stats) *stats = st;
    return gmm;
  }
  // log N(x_n | k) does not change: compute it once, then iterate on the weights only.
  Gmm unit = init;
  for (auto& g : unit.components) g.weight = 1.0;
  const Eigen::MatrixXd log_density = logWeightedDensities(unit, data.points, threads_);
  Eigen::VectorXd log_pi(gmm.size());
  double prev = -std::numeric_limits<double>::infinity();
  for (int it = 0; it < params_.max_iterations; ++it) {
    for (std::size_t k = 0; k < gmm.size(); ++k)
      log_pi[k] = gmm.components[k].weight > 0 ? std::log(gmm.components[k].weight)
                                               : -std::numeric_limits<double>::infinity();
    Eigen::MatrixXd lp = log_density.colwise() + log_pi;
    Eigen::VectorXd lse;
    softmaxCols(lp, lse, threads_);
    st.log_likelihood = w.dot(lse) / total;
    st.iterations = it + 1;
    if (st.log_likelihood - prev < params_.tolerance) {
      st.converged = true;
      break;
    }
    prev = st.log_likelihood;
    const Eigen::VectorXd nk = lp * w;
    for (std::size_t k = 0; k < gmm.size(); ++k) gmm.components[k].weight = nk[k] / total;
  }
  if (stats) *stats = st;
  return gmm;
}

}  // namespace novelty_detection
