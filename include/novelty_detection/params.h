// Every tunable of the pipeline, grouped per stage. ROS-free.
//
// This file is the single source of each parameter: its default (the member initialiser),
// its description and its accepted range (the visit() entry). config/default.yaml,
// docs/parameters.md and config/Detector.cfg are generated from it (print_params; tests keep
// them equal), and the ROS shell reads the same names from the private node handle
// (group/name, e.g. ~preprocess/outlier_k).
//
// Each group has visit(f), calling f(name, value&, ParamInfo) for every field, so that
// loaders, writers, validation and documentation all iterate over one list, and
// validate(), which throws std::invalid_argument naming the parameter and its range.
// The file is long by design: one list of every parameter is what keeps them in one place.
#pragma once

#include <limits>
#include <stdexcept>
#include <string>

namespace novelty_detection {

/// What visit() gives with each field: its description and, for numbers, the accepted
/// range [min, max] (bool and string fields have none; their rules are in validate()).
struct ParamInfo {
  const char* doc;
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
};

/// Pre-processing (paper Sec. IV-A): sparse outlier removal, then ground plane removal.
struct PreprocessParams {
  std::string up = "0 0 1";
  std::string reference_origin;
  std::string current_origin;
  bool sensor_frame = false;
  int max_points = 2000000;
  double min_range_m = 0.0;
  std::string body_box;
  std::string ignore_regions;
  bool self_filter = true;
  double self_max_range_m = 1.5;
  bool outlier_removal = true;
  int outlier_k = 8;
  double outlier_std_mul = 3.0;
  bool outlier_range_scaled = true;
  bool ground_removal = true;
  double ground_distance_m = 0.02;
  double ground_max_angle_deg = 10.0;
  int ground_max_iterations = 200;
  double ground_noise_k = 3.0;
  int ground_sample_points = 4096;
  double ground_min_fraction = 0.05;
  double ground_lowest_support = 0.3;

  template <class F>
  void visit(F&& f) {
    f("up", up,
      {"which way is up in the clouds' frame: three numbers (default +z, REP 103) or 'auto' "
       "(the normal of the largest plane below the sensor that bounds the scene from below, "
       "within 45 deg of +z, or of -y for an organised cloud: a camera's optical frame); "
       "ground removal and floor footprints use it (preprocess/up_direction.h)"});
    f("reference_origin", reference_origin,
      {"the reference's sensor origin 'X Y Z' in its frame [m]; empty: from the cloud "
       "(sensor_frame, or its file's VIEWPOINT) (preprocess/sensor_origin.h)"});
    f("current_origin", current_origin,
      {"the current sweep's sensor origin 'X Y Z' [m] for the command-line tool; empty: from "
       "the cloud (ROS sweeps take it from tf)"});
    f("sensor_frame", sensor_frame,
      {"each cloud given without a stated origin is in its own sensor's frame: the sensor is "
       "its origin (a sensor-frame file or bag; organised clouds are taken so anyway)"});
    f("max_points", max_points,
      {"sweeps and reference files with more points are refused (a file from its header, "
       "before its body is read)",
       1, 100000000});
    f("min_range_m", min_range_m,
      {"returns closer than this to their sensor are dropped from both clouds (0: none) [m]", 0.0,
       100.0});
    f("body_box", body_box,
      {"the robot's body as a box in the sensor's frame, 'xmin ymin zmin xmax ymax zmax' [m]: "
       "returns inside it are dropped from both clouds (the robot_self_filter idea with one "
       "box); empty: none"});
    f("ignore_regions", ignore_regions,
      {"boxes of the map (reference) frame where changes are not reported, ';'-separated, each "
       "'xmin ymin zmin xmax ymax zmax [yaw_deg]' [m] (yaw about the vertical through the box's "
       "centre): current points inside are taken as missing, disappearances centred inside are "
       "dropped; empty: none (preprocess/ignore_regions.h)"});
    f("self_filter", self_filter,
      {"drop the robot's own returns: points within self_max_range_m of their sensor that lie "
       "at the same place in the sensor's frame in both sweeps (needs both sensor origins; "
       "preprocess/self_returns.h)"});
    f("self_max_range_m", self_max_range_m,
      {"the robot's own returns are sought within this distance of the sensor [m]", 0.01, 100.0});
    f("outlier_removal", outlier_removal, {"enable statistical outlier removal"});
    f("outlier_k", outlier_k, {"neighbours used for the mean neighbour distance", 1, 1000});
    f("outlier_std_mul", outlier_std_mul,
      {"a point is an outlier when its mean distance exceeds mu + outlier_std_mul * sigma", 0.0,
       100.0});
    f("outlier_range_scaled", outlier_range_scaled,
      {"with a known sensor origin, a point is an outlier only if it is one also among the "
       "mean distances divided by range (the spacing of a scanning sensor grows with range; a "
       "far, sparsely sampled object is not an outlier)"});
    f("ground_removal", ground_removal, {"enable RANSAC ground plane removal"});
    f("ground_distance_m", ground_distance_m,
      {"RANSAC inlier distance to the plane, and the lower bound of the final ground threshold "
       "(see ground_noise_k) [m]",
       1e-4, 1.0});
    f("ground_max_angle_deg", ground_max_angle_deg,
      {"max angle between the ground normal and up (preprocess/up) [deg]", 0.0, 90.0});
    f("ground_max_iterations", ground_max_iterations,
      {"RANSAC iterations for the ground plane", 1, 100000});
    f("ground_noise_k", ground_noise_k,
      {"ground inliers lie within max(ground_distance_m, ground_noise_k * sigma) of the plane, "
       "sigma the floor's noise estimated robustly from the data (Gaussian plus uniform clutter)",
       0.0, 100.0});
    f("ground_sample_points", ground_sample_points,
      {"RANSAC scores plane hypotheses on a random subset of this many points", 3, 100000000});
    f("ground_min_fraction", ground_min_fraction,
      {"no ground is removed unless the plane holds at least this fraction of the points", 0.0,
       1.0});
    f("ground_lowest_support", ground_lowest_support,
      {"of the near-horizontal planes holding at least this fraction of the best one's "
       "support, the one whose inliers lie lowest is the ground (not a table top or the ceiling)",
       0.0, 1.0});
  }
  void validate() const;
};

/// Multi-scale sampling (Pauly et al. 2002 hierarchical clustering; a scale is a tree cut).
/// Defaults: a flat cluster keeps one representative per 13..24 points (walls thin out to
/// ~1/18), while anything with surface variation above 1 % beyond the noise (edges,
/// corners, objects) is split further, down to leaves of <= 4 points. On a simulated 30k
/// corridor sweep this keeps ~2.0k of 30k points (~1.2k of the 19k left after ground and
/// outlier removal), 2-3x denser near edges than on walls. The noise-aware rule keeps that
/// behaviour on noisy sensors, where Pauly's fixed sigma_max reads the noise as curvature.
struct MultiScaleParams {
  int n_max = 24;
  double sigma_max = 0.01;
  bool noise_aware = true;
  double noise_factor = 2.0;

  template <class F>
  void visit(F&& f) {
    f("n_max", n_max, {"clusters with more points are split (coarse scale)", 1, 1000000});
    f("sigma_max", sigma_max,
      {"clusters with a larger surface variation are split", 0.0, 1.0 / 3.0});
    f("noise_aware", noise_aware,
      {"compute the surface variation from l0 minus noise_factor times the noise variance "
       "estimated from the tree (a cluster as thin as the noise counts as flat)"});
    f("noise_factor", noise_factor,
      {"multiple of the estimated noise variance discounted", 0.0, 100.0});
  }
  void validate() const;
};

/// Gaussian mixture fitting by EM (paper Sec. IV-B; rules in gmm.h).
struct GmmParams {
  int max_components = 64;
  double points_per_component = 300;
  int max_fit_points = 1500;
  int max_iterations = 30;
  double tolerance = 1e-3;
  double min_variance_m2 = 1e-4;
  bool current_from_reference = true;
  int max_extra_components = 16;
  int seed = 42;

  template <class F>
  void visit(F&& f) {
    f("max_components", max_components, {"maximum number of Gaussians per mixture", 1, 4096});
    f("points_per_component", points_per_component,
      {"number of Gaussians = clamp(ceil(points / points_per_component), 1, max_components)", 1.0,
       1e9});
    f("max_fit_points", max_fit_points,
      {"EM is fitted on the multi-scale cut, coarsened until it has about this many clusters", 1,
       100000000});
    f("max_iterations", max_iterations, {"EM iteration cap", 1, 10000});
    f("tolerance", tolerance,
      {"EM stops when the mean log-likelihood gains less than this", 0.0, 1.0});
    f("min_variance_m2", min_variance_m2,
      {"covariance regularisation added to the diagonal [m^2]", 1e-12, 1.0});
    f("current_from_reference", current_from_reference,
      {"start EM on the current sweep from the reference mixture plus Gaussians seeded on "
       "points far from the map (else k-means++ from scratch)"});
    f("max_extra_components", max_extra_components,
      {"maximum number of Gaussians seeded on current points far from the reference", 0, 4096});
    f("seed", seed, {"random seed; results are deterministic for a seed", 0, 2147483647});
  }
  void validate() const;
};

/// Earth Mover's Distance between mixtures and the greedy novelty selection (Algorithm 1;
/// the stop rule is stated in novelty_selection.h).
struct SelectionParams {
  std::string ground_distance = "wasserstein";
  double min_relative_decrease = 0.02;
  double u_th = 0.0;
  double u_th_noise_factor = 0.1;
  int max_novel_gaussians = 32;

  template <class F>
  void visit(F&& f) {
    f("ground_distance", ground_distance,
      {"ground distance between Gaussians: wasserstein (2-Wasserstein) or euclidean (means)"});
    f("min_relative_decrease", min_relative_decrease,
      {"greedy selection stops when the best removal lowers the EMD by less than this fraction",
       0.0, 1.0});
    f("u_th", u_th, {"greedy selection stops when the EMD falls below this [m]", 0.0, 1000.0});
    f("u_th_noise_factor", u_th_noise_factor,
      {"... or below u_th_noise_factor times the data-derived novelty distance "
       "(segmentation/novelty_distance_factor)",
       0.0, 1000.0});
    f("max_novel_gaussians", max_novel_gaussians, {"maximum number of novel Gaussians", 0, 4096});
  }
  void validate() const;
};

/// Candidates the reference could not see (occluded from its sensor origin or out of its
/// view): they are kept out of the novelties unless one of these rules says otherwise (rules
/// in segmentation/hidden_segments.h). Part of the segmentation group; distances scale with
/// tau, the novelty distance.
struct HiddenParams {
  bool unexplained = false;
  bool segments = true;
  bool continuations = true;
  double max_growth = 1.0;
  double ring_factor = 4.0;
  double plane_factor = 0.5;
  double parallel_factor = 2.0;
  double max_coplanar = 0.25;
  double outline_factor = 2.0;
  double min_free_edge = 0.25;

  template <class F>
  void visit(F&& f) {
    f("hidden_unexplained", unexplained,
      {"a point the reference could not see is still novel when the reference mixture does not "
       "explain it (density below the map_likelihood_quantile of the map's own points)"});
    f("hidden_segments", segments,
      {"a segment of candidates hidden from the reference is novel when it is mostly occluded, "
       "a plane patch, not a coplanar continuation of the map structure around it and has "
       "free edges in the current view (a door leaf swung into space the old leaf hid; rule "
       "in hidden_segments.h); a revealed wall is none of the last two"});
    f("hidden_continuations", continuations,
      {"candidates hidden from the map that are linked to a novel segment (closer than the "
       "segments' link radius, directly or through each other) join it: a moved object "
       "reaching into the map's shadow is one object; not when what they would add is a "
       "revealed surface that continues the map's plane and not the segment's (the recess "
       "beside a swung door leaf; hidden_segments.h)"});
    f("hidden_max_growth", max_growth,
      {"continuations add at most hidden_max_growth times a segment's own points, nearest "
       "links first: the part the map saw is the evidence for the part it could not see, and a "
       "segment does not run on through a whole newly seen room",
       0.0, 1000.0});
    f("hidden_ring_factor", ring_factor,
      {"hidden segments: reference structure (no ground, not disappeared) within "
       "hidden_ring_factor * tau of the segment is what it could continue",
       0.0, 1000.0});
    f("hidden_plane_factor", plane_factor,
      {"hidden segments: a structure point within hidden_plane_factor * tau of the segment's "
       "plane continues it",
       0.0, 1000.0});
    f("hidden_parallel_factor", parallel_factor,
      {"hidden segments: a structure point within hidden_parallel_factor * tau of the "
       "segment's plane whose own surface is parallel to it continues it too (a map seen from "
       "a slightly wrong pose lies beside the sweep's surfaces, offset in proportion to range); "
       "0: only hidden_plane_factor",
       0.0, 1000.0});
    f("hidden_max_coplanar", max_coplanar,
      {"hidden segments: the segment continues the map (revealed, not novel) when at least "
       "this share of the structure around it lies on its plane",
       0.0, 1.0});
    f("hidden_outline_factor", outline_factor,
      {"hidden segments: the current sweep's rays within hidden_outline_factor * tau (at the "
       "segment's range) around the segment form its outline",
       0.0, 1000.0});
    f("hidden_min_free_edge", min_free_edge,
      {"hidden segments: novel only when at least this share of the outline rays that reach "
       "its plane or beyond reach past it (free edges: it stands in space)",
       0.0, 1.0});
  }
};

/// Labelling every input point from the novel Gaussians (ChoosePtfromGaussian).
struct SegmentationParams {
  double posterior_threshold = 0.5;
  double novelty_distance_factor = 6.0;
  double min_novelty_distance_m = 0.0;
  double noise_floor_factor = 3.0;
  double link_factor = 2.5;
  double merge_gap_factor = 4.0;
  double merge_floor_gap_factor = 2.0;
  int min_segment_points = 20;
  double object_share = 0.6;
  double crease_offset_factor = 3.0;
  double crease_radius_factor = 2.0;
  double map_likelihood_quantile = 0.0;
  bool visibility_check = true;
  bool sparse_groups = true;
  bool free_groups = true;
  bool free_continuations = true;
  bool own_spacing_links = true;
  bool turned_surfaces = true;
  double turned_angle_deg = 30.0;
  double turned_radius_factor = 2.0;
  HiddenParams hidden;

  template <class F>
  void visit(F&& f) {
    f("posterior_threshold", posterior_threshold,
      {"a point is novel when the novel Gaussians' posterior exceeds this", 0.0, 1.0});
    f("novelty_distance_factor", novelty_distance_factor,
      {"a novel point must lie farther from the map than tau = median + factor * 1.4826 * MAD "
       "of the current-to-reference nearest-neighbour distances",
       0.0, 1000.0});
    f("min_novelty_distance_m", min_novelty_distance_m, {"lower bound of tau [m]", 0.0, 100.0});
    f("noise_floor_factor", noise_floor_factor,
      {"tau is at least this many times the sensor's noise sigma at the sweep's median range, "
       "sigma(r) = c r^p (p = 0, 1 or 2) fitted to the thickness of the sweep's own planar "
       "patches (preprocess/range_noise.h); 0 disables",
       0.0, 100.0});
    f("link_factor", link_factor,
      {"novel points closer than link_factor * their median 4-NN spacing join one segment", 0.1,
       100.0});
    f("merge_gap_factor", merge_gap_factor,
      {"connected pieces mostly owned by the same novel Gaussian merge into one segment when "
       "their bounding boxes are closer than merge_gap_factor link radii",
       0.0, 1000.0});
    f("merge_floor_gap_factor", merge_floor_gap_factor,
      {"and only when their footprints on the floor (x, y) are closer than this many link "
       "radii: the gaps between tilt lines on one object are vertical, while two objects side "
       "by side are apart on the floor (and, with the sweep's origin known, pieces whose "
       "footprints are apart stay apart when the sweep's beams passed between them, or when "
       "it saw one in front of the other: more than this many link radii deeper along "
       "neighbouring rays)",
       0.0, 1000.0});
    f("min_segment_points", min_segment_points,
      {"segments with fewer points are dropped", 1, 100000000});
    f("object_share", object_share,
      {"a segment whose novel points make up at least this share of the object they lie on "
       "(its connected piece of the sweep without the ground, at the link radius) takes the "
       "whole object: the parts of a new object that lie on a surface the map had (where an "
       "old object stood) are new too (1 disables)",
       0.0, 1.0});
    f("crease_offset_factor", crease_offset_factor,
      {"objects that touch are parted where their surfaces meet in a concave crease: a point "
       "whose neighbours' centroid lies on the sensor's side of it by more than this many "
       "noise sigmas (the sweep's range noise model at its range) ends the object it is "
       "reached from (rule in segmentation/surface_creases.h; needs the sensor origin; 0 "
       "disables)",
       0.0, 1000.0});
    f("crease_radius_factor", crease_radius_factor,
      {"the crease test's neighbourhood radius, in link radii", 0.1, 100.0});
    f("map_likelihood_quantile", map_likelihood_quantile,
      {"a point whose density under the reference mixture exceeds this quantile of the map's "
       "own points' densities lies on a mapped surface and is not novel (0 disables)",
       0.0, 1.0});
    f("visibility_check", visibility_check,
      {"a novel point must lie in space the reference sweep saw as free (needs the reference "
       "viewpoint, PCD VIEWPOINT / sensor_origin_; skipped when it is the origin); see the "
       "visibility group"});
    f("sparse_groups", sparse_groups,
      {"compact groups among the points sparse outlier removal took (a small object far away, "
       "sampled by a few scan lines) are novel where they stand in space the reference saw as "
       "free, farther from the map than tau and than their own sampling spacing: a group "
       "touching a segment joins it, one of at least min_segment_points points spreading in "
       "two directions is a segment of its own (segmentation/sparse_groups.h; needs both "
       "sensor origins)"});
    f("free_groups", free_groups,
      {"the same groups over the kept points no segment holds (farther from the map than tau "
       "and their sampling spacing, in space the reference saw as free): one of at least "
       "min_segment_points points that stands upright over several tilt lines is a segment "
       "of its own: a far object no selected Gaussian owns "
       "(segmentation/sparse_groups.h; needs both sensor origins)"});
    f("free_continuations", free_continuations,
      {"points the novel Gaussians' posterior turned down that lie farther than tau from the "
       "map, in space the reference saw as free, join the segment they are linked to (within "
       "the link radius, through each other; at most as many as the segment has): the part "
       "of a new object that a Gaussian shared with the structure it touches holds "
       "(segmentation/free_continuations.h; needs the reference's sensor origin)"});
    f("own_spacing_links", own_spacing_links,
      {"a segment sampled more sparsely than the sweep (a surface seen at a grazing angle, a "
       "far object) links its free continuations at link_factor times its own points' median "
       "4-NN spacing, at most merge_gap_factor link radii "
       "(segmentation/free_continuations.h)"});
    f("turned_surfaces", turned_surfaces,
      {"points within tau of the map whose surface runs along another horizontal direction "
       "in the sweep than in the map (a door leaf next to its hinge, where the old leaf "
       "stood) join the segment they are linked to, after object completion "
       "(segmentation/turned_surfaces.h)"});
    f("turned_angle_deg", turned_angle_deg,
      {"the two directions must be more than this far apart [deg]; about three times the "
       "direction's error on a scan line at the suite's noise",
       1.0, 89.0});
    f("turned_radius_factor", turned_radius_factor,
      {"the neighbourhoods whose directions are compared, in link radii", 0.5, 20.0});
    hidden.visit(f);
  }
  void validate() const;
};

/// Visibility reasoning: what the reference sweep observed as free, occupied or
/// unknown, as a spherical range image from its sensor origin (rules in visibility.h), the
/// newly visible points and the disappearances. Sizes and margins scale with the data: the
/// cell with the sweep's angular spacing, margins with tau (segmentation group), the data's
/// noise and sampling mismatch.
struct VisibilityParams {
  double cell_factor = 1.0;
  double fill_factor = 1.5;
  double margin_factor = 1.0;
  int max_cells = 4000000;
  double slack_factor = 0.05;
  bool newly_visible = true;
  bool disappearances = true;
  double disappearance_margin_factor = 1.0;
  int min_disappeared_points = 20;

  template <class F>
  void visit(F&& f) {
    f("cell_factor", cell_factor,
      {"cell of the spherical range images = cell_factor * the sweep's mean angular spacing "
       "sqrt(covered solid angle / returns)",
       0.1, 100.0});
    f("fill_factor", fill_factor,
      {"empty runs of range image cells between two returns (the gaps between scan lines) up "
       "to fill_factor * the 90th percentile of such runs are filled from the two returns: "
       "seen, not unknown",
       0.0, 100.0});
    f("margin_factor", margin_factor,
      {"a point is in free space when its range from the reference origin is shorter than the "
       "reference's returns around its ray by more than margin_factor * tau, occluded when "
       "longer by more than that",
       0.0, 100.0});
    f("max_cells", max_cells, {"upper bound on the cells of a range image", 1000, 100000000});
    f("slack_factor", slack_factor,
      {"a current point far from the map is compared with its own cell's ranges widened by "
       "slack_factor * the spread of ranges in the 3x3 cells around it (grazing surfaces, "
       "depth edges); disappearances use the whole 3x3 window",
       0.0, 10.0});
    f("newly_visible", newly_visible,
      {"report current points far from the map in space the reference never observed "
       "(occluded or out of view) as newly visible"});
    f("disappearances", disappearances,
      {"report reference points the current sweep sees through (needs the current sensor "
       "origin, sensor_origin_ / PCD VIEWPOINT; skipped when it is the origin)"});
    f("disappearance_margin_factor", disappearance_margin_factor,
      {"a reference point has disappeared when the current returns around its ray from the "
       "current origin are all farther than its range + disappearance_margin_factor * tau",
       0.0, 100.0});
    f("min_disappeared_points", min_disappeared_points,
      {"disappeared segments with fewer reference points are dropped", 1, 100000000});
  }
  void validate() const;
};

/// Superquadric recovery (Sec. V): LM fit of eq. 3, multi-scale refinement, split and merge.
/// Sizes are bounded relative to h, the largest half extent of the fitted points along their
/// principal axes, so the bounds scale with the data.
struct SuperquadricParams {
  bool enabled = true;
  double epsilon_min = 0.1;
  double epsilon_max = 1.9;
  double corner_gain = 0.25;
  bool bounded_fit = true;
  double outside_weight = 1.0;
  double support_weight = 1.0;
  double surface_weight = 1.0;
  double support_fraction = 0.5;
  bool upright = true;
  double mirror_max_free = 0.1;
  int bound_points = 400;
  int max_iterations = 50;
  double function_tolerance = 1e-6;
  bool autodiff = false;
  double min_size_m = 0.005;
  double min_size_fraction = 0.05;
  double max_size_factor = 1.25;
  std::string robust_loss = "none";
  double robust_loss_scale = 0.2;
  int screening_points = 64;
  int screening_iterations = 5;
  int max_fit_points = 600;
  int split_max_points = 2400;
  int split_min_points = 40;
  int split_fit_points = 80;
  int split_iterations = 15;
  double split_gain = 0.9;
  double split_force_factor = 1.25;
  double merge_tolerance = 0.25;
  double one_part_tolerance = 0.5;
  double error_floor_m = 0.002;
  double noise_factor = 1.5;
  double neighbour_distance_factor = 1.0;
  int max_parts = 8;
  bool standing_parts = true;

  template <class F>
  void visit(F&& f) {
    f("enabled", enabled, {"fit superquadrics to the novelty segments"});
    f("epsilon_min", epsilon_min, {"lower bound of the shape exponents e1, e2", 0.01, 2.0});
    f("epsilon_max", epsilon_max, {"upper bound of the shape exponents e1, e2", 0.01, 4.0});
    f("corner_gain", corner_gain,
      {"a segment's whole fit, and each part of one split into several, keeps shape exponents "
       "away from 1 (corners, flat faces) only when they lower its mean surface distance by "
       "more than this fraction of an ellipsoid's (e1 = e2 = 1) fit from the same pose; else "
       "the ellipsoid is kept (a one-sided view of a round object or limb stays round); 0: the "
       "exponents are always free",
       0.0, 10.0});
    f("bounded_fit", bounded_fit,
      {"a segment's final fit is bounded by what the sweep observed around it: it pays for "
       "containing space the sensor saw through or surfaces that are not the segment's, and an "
       "object whose points come down to the floor, or whose lowest scan line is the floor at "
       "its foot with no free space seen beneath it, reaches the floor (shape/fit_bounds.h)"});
    f("outside_weight", outside_weight,
      {"weight of the points a bounded fit must not contain (free space, other surfaces), "
       "relative to the segment's own points; 0: not used",
       0.0, 1000.0});
    f("support_weight", support_weight,
      {"weight of the floor support of a standing object, relative to all its points moved by "
       "the same distance; 0: no support",
       0.0, 1000.0});
    f("surface_weight", surface_weight,
      {"weight of each point's first-order distance to the surface, added to eq. 3's residual in "
       "a bounded fit: eq. 3's volume factor lets a fit cut through its points and shrink, the "
       "distance alone lets it grow; 0: eq. 3 alone",
       0.0, 100.0});
    f("support_fraction", support_fraction,
      {"an object stands on the floor when its lowest point lies within the floor band plus "
       "support_fraction times its own height above the floor (or when it rests on the floor: "
       "shape/fit_bounds.h)",
       0.0, 1.0});
    f("upright", upright,
      {"a bounded fit of an object standing on the floor keeps one axis along up and turns only "
       "about it"});
    f("mirror_max_free", mirror_max_free,
      {"a bounded whole fit of a standing object also fits its points reflected about the "
       "vertical axis through the middle of its silhouette (the hidden side by symmetry), "
       "unless more than this fraction of the reflected points lie in space the sweep saw "
       "through; 0: no mirroring",
       0.0, 1.0});
    f("bound_points", bound_points,
      {"at most this many outside points bound one fit (evenly thinned)", 1, 100000000});
    f("max_iterations", max_iterations, {"Levenberg-Marquardt iteration cap per fit", 1, 10000});
    f("function_tolerance", function_tolerance,
      {"Levenberg-Marquardt stops when the cost changes relatively less than this", 0.0, 1.0});
    f("autodiff", autodiff,
      {"use automatic differentiation instead of the (equal, faster) analytic Jacobian"});
    f("min_size_m", min_size_m,
      {"absolute lower bound of the half sizes a1, a2, a3 [m]", 1e-6, 100.0});
    f("min_size_fraction", min_size_fraction,
      {"half sizes are at least this fraction of the points' largest half extent", 0.0, 1.0});
    f("max_size_factor", max_size_factor,
      {"half sizes (and the centre's offset) are at most this multiple of the largest half "
       "extent",
       1.0, 100.0});
    f("robust_loss", robust_loss, {"robust loss on eq. 3's residuals: none, huber or cauchy"});
    f("robust_loss_scale", robust_loss_scale,
      {"robust loss scale as a fraction of sqrt(a1 a2 a3) of the start model", 1e-6, 100.0});
    f("screening_points", screening_points,
      {"points used to compare the initial guesses of a fit", 11, 100000000});
    f("screening_iterations", screening_iterations,
      {"Levenberg-Marquardt iterations per initial guess while comparing them", 0, 10000});
    f("max_fit_points", max_fit_points,
      {"a segment's points are deterministically subsampled to at most this many", 11, 100000000});
    f("split_max_points", split_max_points,
      {"split and merge works on a deterministic subsample of at most this many points", 11,
       100000000});
    f("split_min_points", split_min_points,
      {"a part is not split into halves smaller than this", 4, 100000000});
    f("split_fit_points", split_fit_points,
      {"parts are subsampled to at most this many points for split and merge fits", 11, 100000000});
    f("split_iterations", split_iterations,
      {"Levenberg-Marquardt iteration cap of the fits that only rank splits and merges (the "
       "final parts are polished with max_iterations)",
       1, 10000});
    f("split_gain", split_gain,
      {"split a part when the halves' points-weighted mean distance is below "
       "split_gain times the part's",
       0.0, 1.0});
    f("split_force_factor", split_force_factor,
      {"a part whose mean distance exceeds split_force_factor times the exact-fit level is "
       "split even if its halves do not fit better",
       1.0, 1e6});
    f("merge_tolerance", merge_tolerance,
      {"merge two neighbours when the merged fit is exact, or its mean distance is at most "
       "(1 + merge_tolerance) times the worse part's and its volume at most (1 + "
       "merge_tolerance) times their sum",
       0.0, 10.0});
    f("one_part_tolerance", one_part_tolerance,
      {"a segment is one part, without split and merge, when its bounded fit (free space, floor, "
       "hidden side) explains its points within (1 + one_part_tolerance) times the level at which "
       "split and merge calls a fit exact: the bounds keep that fit from following its points as "
       "closely as a free fit can; negative: always split and merge",
       -1.0, 10.0});
    f("error_floor_m", error_floor_m,
      {"a fit with a smaller mean distance to its points is exact: it is not split, merges into it "
       "are "
       "allowed [m]",
       0.0, 10.0});
    f("noise_factor", noise_factor,
      {"a fit whose mean distance is below noise_factor times the estimated sensor noise "
       "(local plane RMS) is exact: it is not split, merges into it are allowed; a part is also "
       "not split when its mean distance is below (1 + merge_tolerance) sqrt(2/pi) times the "
       "noise in its own residuals",
       0.0, 100.0});
    f("neighbour_distance_factor", neighbour_distance_factor,
      {"two parts are neighbours when their points come closer than this times the radius of a "
       "typical two-dimensional 12-point neighbourhood",
       0.5, 100.0});
    f("max_parts", max_parts, {"maximum number of superquadrics per segment", 1, 1024});
    f("standing_parts", standing_parts,
      {"a tall segment standing on the floor (at least 2.5 times as tall as wide, deeper than a "
       "flat view) is cut where its horizontal section steps, into legs, trunk, arms and head, "
       "each band into the pieces it falls into (two legs side by side), instead of by split "
       "and merge when that gives 2 to max_parts parts; each part is also fitted with its "
       "hidden side by symmetry (shape/standing_parts.h)"});
  }
  void validate() const;
};

/// Fine alignment of the current sweep against the reference before comparison
/// (alignment.h): robust point-to-plane ICP on reference planes, bounded and reported.
struct AlignmentParams {
  bool enabled = true;
  double max_translation_m = 0.2;
  double max_rotation_deg = 5.0;
  int max_iterations = 30;
  double convergence_translation_m = 1e-4;
  double convergence_rotation_deg = 0.002;
  double robust_scale_factor = 3.0;
  double gate_shrink = 0.5;
  int sample_points = 3000;
  int plane_cell_points = 100;
  double planarity = 0.25;
  double degeneracy_ratio = 0.001;
  double min_inlier_fraction = 0.25;
  int min_correspondences = 50;
  double min_cost_reduction = 0.04;

  template <class F>
  void visit(F&& f) {
    f("enabled", enabled,
      {"refine the current sweep's pose against the reference (point-to-plane ICP) before "
       "comparison, applied when it is within the bounds and lowers the cost by "
       "min_cost_reduction; off saves its time (a few ms a sweep) where localisation is "
       "trusted"});
    f("max_translation_m", max_translation_m,
      {"a correction moving the sensor origin farther is rejected (pose left unchanged) [m]", 0.0,
       100.0});
    f("max_rotation_deg", max_rotation_deg,
      {"a correction rotating more is rejected (pose left unchanged) [deg]", 0.0, 180.0});
    f("max_iterations", max_iterations, {"Gauss-Newton iteration cap", 1, 1000});
    f("convergence_translation_m", convergence_translation_m,
      {"converged when a step moves the sample by less than this [m] ...", 0.0, 1.0});
    f("convergence_rotation_deg", convergence_rotation_deg,
      {"... and rotates it by less than this, once the gate reached the noise level [deg]", 0.0,
       10.0});
    f("robust_scale_factor", robust_scale_factor,
      {"Tukey biweight scale on point-to-plane residuals: this many robust sigmas (1.4826 MAD) "
       "of the residuals, at least this many times the map's point noise (median RMS "
       "thickness of its planes), at most the correspondence distance",
       0.5, 100.0});
    f("gate_shrink", gate_shrink,
      {"the correspondence distance starts at twice the bound and is multiplied by this "
       "whenever a step moved the sample by less than a quarter of it, down to the noise "
       "cut-off",
       0.05, 1.0});
    f("sample_points", sample_points,
      {"the sweep is reduced to about this many points (every k-th in input order, weighted by "
       "1 / samples in their voxel, voxel size from the data)",
       10, 10000000});
    f("plane_cell_points", plane_cell_points,
      {"reference planes are fitted in cubic cells sized so that the cell of a typical map point "
       "holds about this many points (median over points)",
       5, 100000});
    f("planarity", planarity,
      {"a reference cell is a plane when its smallest covariance eigenvalue is below "
       "planarity times the middle one (lines and corners are not used)",
       0.0, 1.0});
    f("degeneracy_ratio", degeneracy_ratio,
      {"pose directions whose information (normal-equation eigenvalue, rotations scaled by "
       "the sample radius) is below this fraction of the largest are left uncorrected",
       0.0, 1.0});
    f("min_inlier_fraction", min_inlier_fraction,
      {"a correction with a smaller share of inlier samples is rejected", 0.0, 1.0});
    f("min_correspondences", min_correspondences,
      {"a correction supported by fewer matched samples is rejected", 6, 100000000});
    f("min_cost_reduction", min_cost_reduction,
      {"a correction is applied only when it lowers the sweep's robust point-to-plane cost "
       "(Tukey, at the final cut-off; a sample without a plane within reach counts in full) "
       "by at least this share of its cost at the given pose: a sweep taken from another "
       "viewpoint than the map's is turned along directions its structure hardly constrains, "
       "at almost no gain",
       0.0, 1.0});
  }
  void validate() const;
};

/// How the work is spread over the CPU's cores. Results do not depend on it: parallel
/// loops only compute independent items (neighbourhoods, superquadric fits) into fixed slots.
struct ComputeParams {
  int threads = 0;

  template <class F>
  void visit(F&& f) {
    f("threads", threads,
      {"threads for the parallel stages: the neighbour statistics of outlier removal, the "
       "trees, EM's E-steps, the novelty selection's EMD solves, the distances to the map, "
       "the visibility tests, object completion's crease tests and the superquadric fits (0: "
       "the hardware concurrency, at most 8; 1: single-threaded); results are identical for "
       "any value",
       0, 256});
  }
  void validate() const;
  /// The thread count to use: threads, or the capped hardware concurrency when 0.
  int resolved() const;
};

/// Changes over time (tracking/change_tracker.h): in a stream of sweeps (the ROS node), each
/// sweep's novelties and disappearances are associated with those of the sweeps before.
struct TrackingParams {
  int confirm_sweeps = 2;
  int forget_sweeps = 2;
  double gate_m = 0.3;
  double min_overlap = 0.3;

  template <class F>
  void visit(F&& f) {
    f("confirm_sweeps", confirm_sweeps,
      {"a change is confirmed once it was detected in this many sweeps (1: at once)", 1, 1000});
    f("forget_sweeps", forget_sweeps,
      {"a tracked change is dropped after this many sweeps in a row that covered its place "
       "without detecting it (a person who walked on)",
       1, 1000});
    f("gate_m", gate_m,
      {"a detection continues a track when their centroids are at most this far apart [m] ...", 0.0,
       100.0});
    f("min_overlap", min_overlap,
      {"... or when their bounding boxes overlap by at least this intersection over union", 0.0,
       1.0});
  }
  void validate() const;
};

/// All parameters. Group names are the YAML sections and ROS parameter namespaces.
struct Params {
  PreprocessParams preprocess;
  MultiScaleParams multiscale;
  GmmParams gmm;
  SelectionParams selection;
  SegmentationParams segmentation;
  VisibilityParams visibility;
  SuperquadricParams superquadric;
  AlignmentParams alignment;
  ComputeParams compute;
  TrackingParams tracking;

  /// Calls f(group, name, value&, info) for every parameter.
  template <class F>
  void visit(F&& f) {
    auto in = [&f](const char* group) {
      return [&f, group](const char* name, auto& value, const ParamInfo& info) {
        f(group, name, value, info);
      };
    };
    preprocess.visit(in("preprocess"));
    multiscale.visit(in("multiscale"));
    gmm.visit(in("gmm"));
    selection.visit(in("selection"));
    segmentation.visit(in("segmentation"));
    visibility.visit(in("visibility"));
    superquadric.visit(in("superquadric"));
    alignment.visit(in("alignment"));
    compute.visit(in("compute"));
    tracking.visit(in("tracking"));
  }

  /// Throws std::invalid_argument naming the first invalid parameter.
  void validate() const;
};

}  // namespace novelty_detection
