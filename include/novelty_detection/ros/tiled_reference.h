// A reference map split into square tiles, with cached reference models per set of tiles.
// ROS-free (kept beside the nodelet, its only user).
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <unordered_map>
#include <utility>
#include <vector>

#include "novelty_detection/pipeline.h"

namespace novelty_detection {

/// A map larger than one sweep is compared only where the sweep can see: the tiles
/// (squares of `tile_size_m` in x, y; all z) that overlap the sweep's box. The reference
/// model (pre-processing + mixture) of a set of tiles is built once and kept in a small
/// LRU cache keyed by that set, so a robot standing still or patrolling a loop does not
/// re-model the map each sweep. tile_size_m <= 0 means one tile: the whole map.
/// Thread-safe.
class TiledReference {
 public:
  TiledReference(const Params& params, double tile_size_m, std::size_t cache_size);

  /// Replaces the map (fixed frame) and drops every cached model. Non-finite points are
  /// ignored. The map's sensor_origin_/sensor_orientation_ (its viewpoint, zero when
  /// unknown) are passed on to every crop, and so are `views` (types.h: a map of several
  /// sweeps), each crop keeping the sweeps it holds points of. Throws std::invalid_argument
  /// for a map without finite points, or views that do not match it.
  void setMap(const Cloud& map, const ReferenceViews& views = {});
  bool hasMap() const;
  /// A copy of the map as given (for saving it).
  Cloud map() const;
  /// A copy of its views (empty for a one-viewpoint map).
  ReferenceViews views() const;
  std::size_t mapSize() const;

  /// The pipeline whose reference is the map cropped to the tiles overlapping the box
  /// [lo, hi] (x, y only). Throws std::logic_error without a map, std::runtime_error when
  /// no map point lies in that box, and whatever Pipeline::setReference throws. A new model
  /// is built without holding the lock, so the other members answer meanwhile.
  std::shared_ptr<const Pipeline> pipelineFor(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi);

  /// New parameters (validated by the caller) for the models built from now on; drops the
  /// cached ones. Detections already running keep the pipeline they hold.
  void setParams(const Params& params);

  std::size_t cachedModels() const;
  std::size_t modelsBuilt() const;

 private:
  using TileKey = std::pair<std::int64_t, std::int64_t>;
  using TileSet = std::vector<TileKey>;
  TileKey tileOf(double x, double y) const;

  Params params_;
  double tile_size_m_;
  std::size_t cache_size_;

  mutable std::mutex mutex_;
  std::shared_ptr<const Cloud> map_;
  std::shared_ptr<const ReferenceViews> views_;
  std::map<TileKey, Indices> tiles_;  // map point indices per tile
  std::list<std::pair<TileSet, std::shared_ptr<const Pipeline>>> cache_;  // front = newest
  std::size_t models_built_ = 0;
  std::uint64_t generation_ = 0;  // bumped when the map or the parameters change
};

}  // namespace novelty_detection
