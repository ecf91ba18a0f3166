// The files novelty_detect writes besides the labels: report.json, superquadrics.json and
// the segment colours of segments.pcd (formats: README.md and docs/ros.md).
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "novelty_detection/io/reference_cache.h"
#include "novelty_detection/pipeline.h"
#include "novelty_detection/types.h"

namespace novelty_detection {
namespace cli {

/// What the run assumed and could check: the sensor origins, up, the floor, the cache.
struct Assumptions {
  std::string reference_origin, current_origin;  ///< how each origin was found
  std::size_t reference_sweeps = 1;              ///< sweeps of a reference directory
  bool visibility_checked = false, disappearances_checked = false;
  ReferenceCacheUse cache;  ///< state "off" without a reference cache
  const Cloud* reference = nullptr;
  const Cloud* current = nullptr;
};

/// A distinct, deterministic colour per segment id (golden-ratio hue walk); grey = not novel.
void colour(int id, std::uint8_t& r, std::uint8_t& g, std::uint8_t& b);

/// superquadrics.json: one entry per superquadric.
nlohmann::json superquadricsJson(const std::vector<Superquadric>& superquadrics);

/// The stage times of one detection [ms] (a stage run twice: the total, stageTotals()), with
/// its wall time as detect_total.
nlohmann::json timingsJson(const Result& r, double detect_ms);

/// report.json.
nlohmann::json reportJson(const Result& r, const Pipeline& pipeline, double reference_ms,
                          double detect_ms, const Assumptions& as);

}  // namespace cli
}  // namespace novelty_detection
