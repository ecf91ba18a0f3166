// A cache of reference models on disk: novelty_detect --reference-cache DIR. Modelling the
// map (pre-processing, the multi-scale cut, EM) costs more than a detection; when the same
// map is compared with sweep after sweep, each run reads it back instead. ROS-free.
//
//   DIR/<key>.refmodel   one model; <key> (16 hex digits) hashes everything it depends on:
//                        the reference cloud's points and sensor pose, its sweep views and
//                        every detector parameter (compute/threads aside). Another map or
//                        setting gives another key, never a stale model.
//
// The file is binary in the writing machine's byte order (a cache, not an exchange format),
// written to a temporary name and renamed into place, and ends with a checksum of its
// contents; a file that fails any check is reported as unreadable and rebuilt.
#pragma once

#include <optional>
#include <string>

#include "novelty_detection/params.h"
#include "novelty_detection/pipeline.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

/// The cache key of a reference model: FNV-1a 64 of the format version, `params` (as YAML,
/// compute/threads set to 0), the cloud's coordinates bit for bit, its sensor origin and
/// orientation, and `views`; 16 lowercase hex digits.
std::string referenceCacheKey(const Params& params, const Cloud& reference,
                              const ReferenceViews& views);

/// DIR/<key>.refmodel.
std::string referenceCachePath(const std::string& dir, const std::string& key);

/// The summary stored under `key` in `dir`: std::nullopt when there is none. Throws
/// std::runtime_error naming the file when it exists but cannot be read, is truncated, too
/// large for the counts it states, of another format or key, or fails its checksum.
std::optional<ReferenceModelSummary> loadReferenceSummary(const std::string& dir,
                                                          const std::string& key);

/// Stores `summary` under `key` in `dir` (created when missing), atomically. Throws
/// std::runtime_error naming the path when it cannot be written.
void saveReferenceSummary(const std::string& dir, const std::string& key,
                          const ReferenceModelSummary& summary);

/// How a reference model was obtained through the cache.
struct ReferenceCacheUse {
  std::string key;
  /// "hit" (read back), "written" (built and stored), "replaced" (the stored one was
  /// unreadable or did not fit the cloud: built and stored again), "not written" (built;
  /// storing it failed).
  std::string state;
  std::string message;  ///< why the cache was not used or not written (empty otherwise)
};

/// pipeline.setReference(reference, views) through the cache in `dir`: the stored summary
/// when there is a valid one, else the model is built and stored. A damaged file or a
/// failed write never fails the run (`message` says what happened); errors of the
/// reference itself propagate as from setReference.
ReferenceCacheUse setReferenceCached(Pipeline& pipeline, const Cloud& reference,
                                     const ReferenceViews& views, const std::string& dir);

}  // namespace novelty_detection
