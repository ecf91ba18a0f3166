#include "novelty_detection/ros/tiled_reference.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "novelty_detection/preprocess/input_check.h"

namespace novelty_detection {

TiledReference::TiledReference(const Params& params, double tile_size_m, std::size_t cache_size)
    : params_(params),
      tile_size_m_(tile_size_m),
      cache_size_(std::max<std::size_t>(cache_size, 1)) {
  params_.validate();
}

TiledReference::TileKey TiledReference::tileOf(double x, double y) const {
  if (tile_size_m_ <= 0.0) return {0, 0};
  // Clamped before the cast: a box corner far out (a wide margin) must not overflow int64.
  const double limit = 1e15;
  auto index = [&](double v) {
    const double t = std::floor(v / tile_size_m_);
    return static_cast<std::int64_t>(std::isnan(t) ? 0.0 : std::clamp(t, -limit, limit));
  };
  return {index(x), index(y)};
}

void TiledReference::setMap(const Cloud& map, const ReferenceViews& views) {
  checkReferenceViews(map, views);
  auto copy = std::make_shared<Cloud>(map);
  auto views_copy = std::make_shared<ReferenceViews>(views);
  std::map<TileKey, Indices> tiles;
  for (std::size_t i = 0; i < copy->size(); ++i) {
    const PointT& p = (*copy)[i];
    if (!usablePoint(p)) continue;  // absurd coordinates would overflow the tile index
    tiles[tileOf(p.x, p.y)].push_back(static_cast<int>(i));
  }
  if (tiles.empty()) {
    throw std::invalid_argument("reference map has no finite points (" +
                                std::to_string(copy->size()) + " points given)");
  }
  std::lock_guard<std::mutex> lock(mutex_);
  map_ = std::move(copy);
  views_ = std::move(views_copy);
  tiles_ = std::move(tiles);
  cache_.clear();
  ++generation_;
}

void TiledReference::setParams(const Params& params) {
  params.validate();
  std::lock_guard<std::mutex> lock(mutex_);
  params_ = params;
  cache_.clear();
  ++generation_;
}

bool TiledReference::hasMap() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return map_ != nullptr;
}

Cloud TiledReference::map() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!map_) throw std::logic_error("no reference map set");
  return *map_;
}

ReferenceViews TiledReference::views() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return views_ ? *views_ : ReferenceViews{};
}

std::size_t TiledReference::mapSize() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return map_ ? map_->size() : 0;
}

std::shared_ptr<const Pipeline> TiledReference::pipelineFor(const Eigen::Vector3d& lo,
                                                            const Eigen::Vector3d& hi) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (!map_) throw std::logic_error("no reference map set");
  TileSet key;
  if (tile_size_m_ <= 0.0) {
    key.push_back({0, 0});
  } else {
    const TileKey a = tileOf(lo.x(), lo.y()), b = tileOf(hi.x(), hi.y());
    // A huge box (e.g. a stray far point) must not loop over millions of empty tiles:
    // walk the occupied tiles instead when the box spans more tiles than exist.
    const double span = double(b.first - a.first + 1) * double(b.second - a.second + 1);
    if (span > static_cast<double>(tiles_.size())) {
      for (const auto& t : tiles_) {
        if (t.first.first >= a.first && t.first.first <= b.first && t.first.second >= a.second &&
            t.first.second <= b.second) {
          key.push_back(t.first);
        }
      }
    } else {
      for (std::int64_t i = a.first; i <= b.first; ++i) {
        for (std::int64_t j = a.second; j <= b.second; ++j) {
          if (tiles_.count({i, j})) key.push_back({i, j});
        }
      }
    }
  }
  if (key.empty()) {
    throw NoOverlapError(
        "the sweep does not overlap the reference: overlap 0.000 (the map has no points "
        "where the sweep is); check the frames and the sensor pose",
        0.0);
  }
  for (auto it = cache_.begin(); it != cache_.end(); ++it) {
    if (it->first == key) {
      cache_.splice(cache_.begin(), cache_, it);
      return cache_.front().second;
    }
  }
  // Every tile: the map as given, with its layout (an organised depth-camera map keeps its
  // image grid, which the up estimate, the noise model and the neighbours use) and its NaN
  // points; otherwise the crop of its finite points in those tiles.
  const bool whole = key.size() == tiles_.size();
  const std::shared_ptr<const Cloud> whole_map = whole ? map_ : nullptr;
  const std::shared_ptr<const ReferenceViews> whole_views = whole ? views_ : nullptr;
  Cloud crop;
  ReferenceViews crop_views;  // the sweeps the crop holds points of, renumbered
  if (!whole) {
    // The map's viewpoint (if known) feeds the pipeline's free-space check.
    crop.sensor_origin_ = map_->sensor_origin_;
    crop.sensor_orientation_ = map_->sensor_orientation_;
    std::vector<std::int64_t> renumbered(views_->origins.size(), -1);
    for (const auto& t : key) {
      for (int i : tiles_.at(t)) {
        crop.push_back((*map_)[i]);
        if (views_->empty()) continue;
        std::int64_t& k = renumbered[views_->sweep[i]];
        if (k < 0) {
          k = static_cast<std::int64_t>(crop_views.origins.size());
          crop_views.origins.push_back(views_->origins[views_->sweep[i]]);
        }
        crop_views.sweep.push_back(static_cast<std::uint32_t>(k));
      }
    }
  }
  // The model is built without the lock (seconds on a large map): the diagnostics, the
  // services and other sweeps read the map meanwhile. It is cached only when neither the
  // map nor the parameters changed during the build, and a model another thread built for
  // the same tiles meanwhile is preferred.
  const Params params = params_;
  const std::uint64_t generation = generation_;
  lock.unlock();
  auto pipeline = std::make_shared<Pipeline>(params);
  if (whole)
    pipeline->setReference(*whole_map, *whole_views);
  else
    pipeline->setReference(crop, crop_views);
  lock.lock();
  ++models_built_;
  if (generation != generation_) return pipeline;
  for (const auto& entry : cache_) {
    if (entry.first == key) return entry.second;
  }
  cache_.emplace_front(std::move(key), pipeline);
  while (cache_.size() > cache_size_) cache_.pop_back();
  return pipeline;
}

std::size_t TiledReference::cachedModels() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return cache_.size();
}

std::size_t TiledReference::modelsBuilt() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return models_built_;
}

}  // namespace novelty_detection
