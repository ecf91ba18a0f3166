// Multi-scale sampling: Pauly, Gross & Kobbelt (2002) hierarchical clustering, as the paper
// uses it (Sec. IV-A). A cluster P is split through its centroid by the plane normal to the
// eigenvector of the largest eigenvalue of its covariance. The binary tree is built once,
// down to small leaves; a scale is a cut of it, cheap to take at any (n_max, sigma_max):
// a node is a cluster of the cut when |P| <= n_max and sigma(P) <= sigma_max (or it is a
// leaf), sigma = l0 / (l0 + l1 + l2) with l0 <= l1 <= l2 the covariance eigenvalues.
#pragma once

#include <vector>

#include "novelty_detection/params.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

class MultiScaleTree {
 public:
  struct Node {
    int begin = 0, end = 0;     ///< range in order() of the node's points
    int left = -1, right = -1;  ///< children, -1 for a leaf
    int parent = -1;
    Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
    Eigen::Matrix3f covariance = Eigen::Matrix3f::Zero();
    float sigma = 0.f;                                      ///< surface variation
    Eigen::Vector3f eigenvalues = Eigen::Vector3f::Zero();  ///< of covariance, ascending
    int size() const { return end - begin; }
    bool isLeaf() const { return left < 0; }
  };

  /// One scale: a set of clusters covering every point of the tree exactly once.
  struct Cut {
    std::vector<int> nodes;               ///< tree node of each cluster
    std::vector<Eigen::Vector3f> points;  ///< representative (centroid) of each cluster
    std::vector<int> sizes;               ///< points per cluster
    std::vector<int> cluster_of;          ///< per INPUT-cloud index: cluster number, -1 if absent
  };

  /// Nodes with at most this many points are leaves (a cut never goes finer). Pauly et al.
  /// build down to single points; 4 keeps the tree at about N/2 nodes while the finest cut
  /// still averages ~3 points per representative.
  static constexpr int kMaxLeafSize = 4;

  /// Builds the tree over cloud[indices] (all finite points when indices is empty),
  /// O(N log N). Non-finite points named in `indices` are left out (cluster -1 in every
  /// cut); an index outside the cloud or given twice throws std::invalid_argument. Clusters
  /// without spread (duplicate points) become leaves of any size. An empty selection gives
  /// an empty tree whose cuts are empty. With `threads` > 1 (large clouds only) the
  /// subtrees below the top three levels grow on the threads, largest first; the tree is the
  /// same.
  void build(const Cloud& cloud, const Indices& indices = {}, int threads = 1);
  /// The scale (n_max, sigma_max): O(number of clusters + cloud size), no rebuild. Throws
  /// std::invalid_argument for n_max < 1 or sigma_max < 0 (or NaN).
  Cut cut(int n_max, double sigma_max) const;
  /// Noise-aware scale: as cut(n_max, sigma_max) with the surface variation computed from
  /// l0 - noise_var_m2 (clamped at 0), i.e. a cluster whose thickness is explained by
  /// sensor noise of that variance counts as flat. noise_var_m2 = 0 is Pauly's rule.
  Cut cut(int n_max, double sigma_max, double noise_var_m2) const;
  /// The scale the parameters name: cut(n_max, sigma_max), or with noise_aware the
  /// noise-aware cut discounting noise_factor * noiseVariance().
  Cut cut(const MultiScaleParams& params) const;
  /// Robust estimate of the noise variance normal to the surfaces [m^2]: the median over
  /// the nodes of 8..64 points (mostly patches of planes, whose thickness is the noise) of
  /// their smallest eigenvalue, corrected for the plane fit's degrees of freedom. 0 for an
  /// empty or tiny tree.
  double noiseVariance() const { return noise_variance_m2_; }
  /// One node's vote in that median: its smallest eigenvalue divided by the median of the
  /// plane fit's chi-square (n - 3 degrees of freedom) [m^2]; -1 for a node that does not
  /// vote (fewer than 16 or more than 256 points, or not plate-like: l1 < 10 l0).
  static double noiseVote(const Node& node);

  const std::vector<Node>& nodes() const { return nodes_; }
  /// Input-cloud indices in tree order: node n owns order()[n.begin, n.end).
  const Indices& order() const { return order_; }
  Indices nodeIndices(int node) const;
  std::size_t cloudSize() const { return cloud_size_; }

 private:
  std::vector<Node> nodes_;
  Indices order_;
  std::size_t cloud_size_ = 0;
  double noise_variance_m2_ = 0.0;
};

}  // namespace novelty_detection
