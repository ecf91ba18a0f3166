// A directory of result files written as one set: a reader sees the previous complete set or
// the new complete set, and can tell when a run was interrupted while replacing it.
#pragma once

#include <string>
#include <vector>

namespace novelty_detection {

/// Files are first written into a private staging directory inside `dir` (mkdtemp, named
/// `.staging-<pid>-XXXXXX`), flushed to disk, then commit() removes `dir/complete`, renames
/// every staged file into `dir`, removes the files the previous marker listed that the new
/// set does not hold, and writes `dir/complete` (the file names, one per line)
/// last. So `complete` present means every file it lists belongs to one run; a run killed
/// before commit leaves the previous set as it was, one killed during commit leaves no
/// `complete`. Staging directories of processes that no longer run are removed when a new
/// set starts; an uncommitted set's staging directory is removed by the destructor.
/// Every failure throws std::runtime_error naming the path, the step and the system's reason.
class OutputSet {
 public:
  static constexpr const char* kMarker = "complete";

  explicit OutputSet(const std::string& dir);
  ~OutputSet();
  OutputSet(const OutputSet&) = delete;
  OutputSet& operator=(const OutputSet&) = delete;

  /// Where to write file `name` (a plain name, no '/') with any writer; commit() takes it.
  std::string stagedPath(const std::string& name);
  /// Writes `text` as file `name` of the set.
  void writeText(const std::string& name, const std::string& text);
  /// Flushes the staged files, replaces the directory's set with them, writes the marker.
  void commit();

 private:
  std::string dir_, staging_;
  std::vector<std::string> names_;
  bool committed_ = false;
};

}  // namespace novelty_detection
