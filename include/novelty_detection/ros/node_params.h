// Parameters of the ROS shell only (frames, files, tiling); the pipeline's own parameters
// are novelty_detection::Params, read by loadRosParams() under the same names as the YAML.
// Each field's description is its visit() text (docs/ros.md lists them).
#pragma once

#include <ros/node_handle.h>

#include <string>

namespace novelty_detection {

struct NodeParams {
  std::string fixed_frame = "map";
  std::string reference_file;
  double tile_size_m = 10.0;
  double crop_margin_m = 1.0;
  std::string sensor_frame;
  double sensor_range_m = 30.0;
  int tile_cache_size = 8;
  int input_queue_size = 5;
  std::string save_directory;
  bool publish_reference = true;
  double reference_display_voxel_m = 0.05;
  bool display_gaussians = false;
  bool keep_freed_buffers = true;

  template <class F>
  void visit(F&& f) {
    f("fixed_frame", fixed_frame, "frame of the reference map and of all outputs");
    f("reference_file", reference_file,
      "PCD/PLY reference map (fixed frame) loaded at start; empty: set one by service");
    f("tile_size_m", tile_size_m,
      "edge of the reference map tiles [m]; <= 0 models the whole map at once");
    f("crop_margin_m", crop_margin_m, "reference kept around the sweep's extent [m]");
    f("sensor_frame", sensor_frame,
      "the reference is also cropped to sensor_range_m around this frame's origin; empty: the "
      "sweep's own frame when it is not the fixed frame");
    f("sensor_range_m", sensor_range_m, "sensor range for that crop [m]");
    f("tile_cache_size", tile_cache_size, "reference models (sets of tiles) kept in memory");
    f("input_queue_size", input_queue_size, "sweeps queued while waiting for their transform");
    f("save_directory", save_directory,
      "~save_reference writes only inside this directory (a relative path is taken inside it; "
      "'..' and symlinks that lead out are refused); empty: $ROS_HOME/novelty_detection "
      "(~/.ros/novelty_detection)");
    f("publish_reference", publish_reference,
      "publish the reference map, latched, on ~reference_cloud for display whenever it is set");
    f("reference_display_voxel_m", reference_display_voxel_m,
      "~reference_cloud keeps one point per voxel of this edge [m] (display only; the "
      "detector uses every point); 0: every point");
    f("display_gaussians", display_gaussians,
      "publish the current sweep's Gaussians on ~gaussians (red: the novel ones that hold "
      "labelled points)");
    f("keep_freed_buffers", keep_freed_buffers,
      "process-wide: freed buffers stay in the heap for the next sweep instead of going back "
      "to the system (saves the page faults of re-mapping megabytes per stage; the manager "
      "keeps its peak size); read at start");
  }
  /// Throws std::invalid_argument naming the parameter.
  void validate() const;
};

/// Reads ~name for every field (defaults from the struct), checks types, validates.
NodeParams loadNodeParams(const ros::NodeHandle& nh);

}  // namespace novelty_detection
