#include "novelty_detection/params.h"

#include <algorithm>
#include <sstream>
#include <thread>

namespace novelty_detection {
namespace {

template <class T>
void requireRange(const char* name, T value, T lo, T hi) {
  if (!(value >= lo && value <= hi)) {
    std::ostringstream msg;
    msg << "parameter " << name << " = " << value << " is out of range [" << lo << ", " << hi
        << "]";
    throw std::invalid_argument(msg.str());
  }
}

}  // namespace

void PreprocessParams::validate() const {
  requireRange("preprocess/max_points", max_points, 1, 100000000);
  requireRange("preprocess/outlier_k", outlier_k, 1, 1000);
  requireRange("preprocess/outlier_std_mul", outlier_std_mul, 0.0, 100.0);
  requireRange("preprocess/ground_distance_m", ground_distance_m, 1e-4, 1.0);
  requireRange("preprocess/ground_max_angle_deg", ground_max_angle_deg, 0.0, 90.0);
  requireRange("preprocess/ground_max_iterations", ground_max_iterations, 1, 100000);
  requireRange("preprocess/ground_noise_k", ground_noise_k, 0.0, 100.0);
  requireRange("preprocess/ground_sample_points", ground_sample_points, 3, 100000000);
  requireRange("preprocess/ground_min_fraction", ground_min_fraction, 0.0, 1.0);
  requireRange("preprocess/ground_lowest_support", ground_lowest_support, 0.0, 1.0);
}

void MultiScaleParams::validate() const {
  requireRange("multiscale/n_max", n_max, 1, 1000000);
  requireRange("multiscale/sigma_max", sigma_max, 0.0, 1.0 / 3.0);
  requireRange("multiscale/noise_factor", noise_factor, 0.0, 100.0);
}

void GmmParams::validate() const {
  requireRange("gmm/max_components", max_components, 1, 4096);
  requireRange("gmm/points_per_component", points_per_component, 1.0, 1e9);
  requireRange("gmm/max_fit_points", max_fit_points, 1, 100000000);
  requireRange("gmm/max_iterations", max_iterations, 1, 10000);
  requireRange("gmm/tolerance", tolerance, 0.0, 1.0);
  requireRange("gmm/min_variance_m2", min_variance_m2, 1e-12, 1.0);
  requireRange("gmm/max_extra_components", max_extra_components, 0, 4096);
  requireRange("gmm/seed", seed, 0, 2147483647);
}

void SelectionParams::validate() const {
  if (ground_distance != "wasserstein" && ground_distance != "euclidean") {
    throw std::invalid_argument("parameter selection/ground_distance = '" + ground_distance +
                                "' must be 'wasserstein' or 'euclidean'");
  }
  requireRange("selection/min_relative_decrease", min_relative_decrease, 0.0, 1.0);
  requireRange("selection/u_th", u_th, 0.0, 1000.0);
  requireRange("selection/u_th_noise_factor", u_th_noise_factor, 0.0, 1000.0);
  requireRange("selection/max_novel_gaussians", max_novel_gaussians, 0, 4096);
}

void SegmentationParams::validate() const {
  requireRange("segmentation/posterior_threshold", posterior_threshold, 0.0, 1.0);
  requireRange("segmentation/novelty_distance_factor", novelty_distance_factor, 0.0, 1000.0);
  requireRange("segmentation/min_novelty_distance_m", min_novelty_distance_m, 0.0, 100.0);
  requireRange("segmentation/link_factor", link_factor, 0.1, 100.0);
  requireRange("segmentation/merge_gap_factor", merge_gap_factor, 0.0, 1000.0);
  requireRange("segmentation/merge_floor_gap_factor", merge_floor_gap_factor, 0.0, 1000.0);
  requireRange("segmentation/min_segment_points", min_segment_points, 1, 100000000);
  requireRange("segmentation/map_likelihood_quantile", map_likelihood_quantile, 0.0, 1.0);
  requireRange("segmentation/hidden_ring_factor", hidden_ring_factor, 0.0, 1000.0);
  requireRange("segmentation/hidden_plane_factor", hidden_plane_factor, 0.0, 1000.0);
  requireRange("segmentation/hidden_max_coplanar", hidden_max_coplanar, 0.0, 1.0);
  requireRange("segmentation/hidden_outline_factor", hidden_outline_factor, 0.0, 1000.0);
  requireRange("segmentation/hidden_min_free_edge", hidden_min_free_edge, 0.0, 1.0);
}

void VisibilityParams::validate() const {
  requireRange("visibility/cell_factor", cell_factor, 0.1, 100.0);
  requireRange("visibility/fill_factor", fill_factor, 0.0, 100.0);
  requireRange("visibility/margin_factor", margin_factor, 0.0, 100.0);
  requireRange("visibility/max_cells", max_cells, 1000, 100000000);
  requireRange("visibility/slack_factor", slack_factor, 0.0, 10.0);
  requireRange("visibility/disappearance_margin_factor", disappearance_margin_factor, 0.0, 100.0);
  requireRange("visibility/min_disappeared_points", min_disappeared_points, 1, 100000000);
}

void SuperquadricParams::validate() const {
  requireRange("superquadric/epsilon_min", epsilon_min, 0.01, 2.0);
  requireRange("superquadric/epsilon_max", epsilon_max, 0.01, 4.0);
  if (epsilon_min >= epsilon_max) {
    throw std::invalid_argument("parameter superquadric/epsilon_min must be below epsilon_max");
  }
  requireRange("superquadric/max_iterations", max_iterations, 1, 10000);
  requireRange("superquadric/function_tolerance", function_tolerance, 0.0, 1.0);
  requireRange("superquadric/min_size_m", min_size_m, 1e-6, 100.0);
  requireRange("superquadric/min_size_fraction", min_size_fraction, 0.0, 1.0);
  requireRange("superquadric/max_size_factor", max_size_factor, 1.0, 100.0);
  if (robust_loss != "none" && robust_loss != "huber" && robust_loss != "cauchy") {
    throw std::invalid_argument("parameter superquadric/robust_loss = '" + robust_loss +
                                "' must be 'none', 'huber' or 'cauchy'");
  }
  requireRange("superquadric/robust_loss_scale", robust_loss_scale, 1e-6, 100.0);
  requireRange("superquadric/screening_points", screening_points, 11, 100000000);
  requireRange("superquadric/screening_iterations", screening_iterations, 0, 10000);
  requireRange("superquadric/max_fit_points", max_fit_points, 11, 100000000);
  requireRange("superquadric/split_max_points", split_max_points, 11, 100000000);
  requireRange("superquadric/split_min_points", split_min_points, 4, 100000000);
  requireRange("superquadric/split_fit_points", split_fit_points, 11, 100000000);
  requireRange("superquadric/split_gain", split_gain, 0.0, 1.0);
  requireRange("superquadric/split_force_factor", split_force_factor, 1.0, 1e6);
  requireRange("superquadric/split_iterations", split_iterations, 1, 10000);
  requireRange("superquadric/merge_tolerance", merge_tolerance, 0.0, 10.0);
  requireRange("superquadric/error_floor_m", error_floor_m, 0.0, 10.0);
  requireRange("superquadric/noise_factor", noise_factor, 0.0, 100.0);
  requireRange("superquadric/neighbour_distance_factor", neighbour_distance_factor, 0.5, 100.0);
  requireRange("superquadric/max_parts", max_parts, 1, 1024);
}

void AlignmentParams::validate() const {
  requireRange("alignment/max_translation_m", max_translation_m, 0.0, 100.0);
  requireRange("alignment/max_rotation_deg", max_rotation_deg, 0.0, 180.0);
  requireRange("alignment/max_iterations", max_iterations, 1, 1000);
  requireRange("alignment/convergence_translation_m", convergence_translation_m, 0.0, 1.0);
  requireRange("alignment/convergence_rotation_deg", convergence_rotation_deg, 0.0, 10.0);
  requireRange("alignment/robust_scale_factor", robust_scale_factor, 0.5, 100.0);
  requireRange("alignment/gate_shrink", gate_shrink, 0.05, 1.0);
  requireRange("alignment/sample_points", sample_points, 10, 10000000);
  requireRange("alignment/plane_cell_points", plane_cell_points, 5, 100000);
  requireRange("alignment/planarity", planarity, 0.0, 1.0);
  requireRange("alignment/degeneracy_ratio", degeneracy_ratio, 0.0, 1.0);
  requireRange("alignment/min_inlier_fraction", min_inlier_fraction, 0.0, 1.0);
  requireRange("alignment/min_correspondences", min_correspondences, 6, 100000000);
}

void ComputeParams::validate() const { requireRange("compute/threads", threads, 0, 256); }

int ComputeParams::resolved() const {
  if (threads > 0) return threads;
  const unsigned hw = std::thread::hardware_concurrency();
  return static_cast<int>(std::min(8u, std::max(1u, hw)));
}

void Params::validate() const {
  preprocess.validate();
  multiscale.validate();
  gmm.validate();
  selection.validate();
  segmentation.validate();
  visibility.validate();
  superquadric.validate();
  alignment.validate();
  compute.validate();
}

}  // namespace novelty_detection
