// The nodelet's sweep path without a ROS master, for the fuzz target fuzz_sweep_path and the
// test that replays its kept inputs. A sweep comes either from bytes decoded as a
// sensor_msgs::PointCloud2 (first byte even; see pointcloud2_from_bytes.h), or as a small
// room with a box (first byte odd) whose points are overwritten in turn by raw 32-bit float
// patterns from the bytes (NaN, infinities, +-FLT_MAX, 1e20, denormals, anything), the whole
// sweep first shifted along x when bit 1 of the first byte is set; then, as the nodelet does:
// the box of usable points grown by a crop margin, the reference's tiles for that box
// (TiledReference, 2 m tiles) and detection.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

#include "novelty_detection/preprocess/input_check.h"
#include "novelty_detection/ros/conversions.h"
#include "novelty_detection/ros/tiled_reference.h"
#include "pointcloud2_from_bytes.h"

namespace novelty_detection {
namespace fuzz {

/// A 6 x 4 x 2.5 m room sampled every 0.1 m (floor, two walls), seen from (3, 1, 1.2);
/// with a 0.5 m square box top 0.5 m above the floor.
inline Cloud room(bool with_box) {
  Cloud c;
  for (float x = 0.0f; x < 6.0f; x += 0.1f)
    for (float y = 0.0f; y < 4.0f; y += 0.1f) c.push_back(PointT(x, y, 0.0f));
  for (float x = 0.0f; x < 6.0f; x += 0.1f)
    for (float z = 0.0f; z < 2.5f; z += 0.1f) c.push_back(PointT(x, 4.0f, z));
  for (float y = 0.0f; y < 4.0f; y += 0.1f)
    for (float z = 0.0f; z < 2.5f; z += 0.1f) c.push_back(PointT(6.0f, y, z));
  if (with_box) {
    for (float x = 3.0f; x < 3.5f; x += 0.05f)
      for (float y = 2.0f; y < 2.5f; y += 0.05f) c.push_back(PointT(x, y, 0.5f));
  }
  c.sensor_origin_ = Eigen::Vector4f(3.0f, 1.0f, 1.2f, 0.0f);
  return c;
}

inline TiledReference& reference() {
  static TiledReference* ref = [] {
    Params params;
    params.compute.threads = 1;
    auto* r = new TiledReference(params, 2.0, 4);
    r->setMap(room(false));
    return r;
  }();
  return *ref;
}

inline Cloud sweepFrom(const std::uint8_t* data, std::size_t size) {
  if (data[0] % 2 == 0) return fromPointCloud2(pointCloud2FromBytes(data + 1, size - 1));
  Cloud c = room(true);
  ByteReader in(data + 1, size - 1);
  // An optional shift of the whole sweep (a wrong frame), then points overwritten in turn.
  const float shift = in.get<float>();
  if (data[0] & 2) {
    for (auto& p : c) p.x += shift;
  }
  for (std::size_t i = 0; in.remaining() >= 12; i = (i + 97) % c.size()) {
    c[i].x = in.get<float>();
    c[i].y = in.get<float>();
    c[i].z = in.get<float>();
  }
  return c;
}

/// What became of one input.
struct SweepOutcome {
  enum Kind { kResult, kNoPoint, kNoOverlap, kRefused } kind = kNoPoint;
  Cloud sweep;
  Result result;
  std::string error;
};

/// Runs one input through the path. Refusals (std::invalid_argument, std::runtime_error,
/// NoOverlapError) are outcomes; anything else propagates.
inline SweepOutcome runSweepPath(const std::uint8_t* data, std::size_t size) {
  SweepOutcome out;
  if (size == 0) return out;
  try {
    out.sweep = sweepFrom(data, size);
    Eigen::Vector3d lo, hi;
    if (!usableBounds(out.sweep, lo, hi)) return out;  // the nodelet refuses it by name
    lo.array() -= 2.0;
    hi.array() += 2.0;
    const auto pipeline = reference().pipelineFor(lo, hi);
    out.result = pipeline->detect(out.sweep);
    out.kind = SweepOutcome::kResult;
  } catch (const NoOverlapError& e) {
    out.kind = SweepOutcome::kNoOverlap;
    out.error = e.what();
  } catch (const std::invalid_argument& e) {
    out.kind = SweepOutcome::kRefused;
    out.error = e.what();
  } catch (const std::runtime_error& e) {
    out.kind = SweepOutcome::kRefused;
    out.error = e.what();
  }
  return out;
}

}  // namespace fuzz
}  // namespace novelty_detection
