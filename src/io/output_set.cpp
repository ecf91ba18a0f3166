#include "novelty_detection/io/output_set.h"

#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>

namespace novelty_detection {
namespace {

namespace fs = std::filesystem;
constexpr const char* kStagingPrefix = ".staging-";

[[noreturn]] void fail(const std::string& path, const std::string& step) {
  throw std::runtime_error("cannot write '" + path + "': " + step + " failed (" +
                           std::strerror(errno) + ")");
}

void fsyncPath(const std::string& path, int flags) {
  const int fd = ::open(path.c_str(), flags | O_CLOEXEC);
  if (fd < 0) fail(path, "open");
  const bool ok = ::fsync(fd) == 0 || errno == EINVAL;  // some filesystems refuse on dirs
  ::close(fd);
  if (!ok) fail(path, "fsync");
}

/// `.staging-<pid>-XXXXXX` of a process that is gone: left by a kill before its commit.
bool isStale(const std::string& name) {
  if (name.rfind(kStagingPrefix, 0) != 0) return false;
  const char* digits = name.c_str() + std::strlen(kStagingPrefix);
  char* end = nullptr;
  const long pid = std::strtol(digits, &end, 10);
  if (end == digits || *end != '-' || pid <= 0) return false;
  return ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH;
}

/// A file name of the set: not empty, no '/', not hidden, not the marker.
bool isPlainName(const std::string& name) {
  return !name.empty() && name.find('/') == std::string::npos && name[0] != '.' &&
         name != OutputSet::kMarker;
}

}  // namespace

OutputSet::OutputSet(const std::string& dir) : dir_(dir) {
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec || !fs::is_directory(dir_)) {
    throw std::runtime_error("cannot write '" + dir_ + "': not a directory that can be created" +
                             (ec ? " (" + ec.message() + ")" : std::string()));
  }
  for (const auto& entry : fs::directory_iterator(dir_, ec)) {
    const std::string name = entry.path().filename().string();
    if (isStale(name) && entry.is_directory() && !entry.is_symlink()) fs::remove_all(entry, ec);
  }
  std::string tmpl =
      (fs::path(dir_) / (kStagingPrefix + std::to_string(::getpid()) + "-XXXXXX")).string();
  if (::mkdtemp(tmpl.data()) == nullptr) fail(tmpl, "creating the staging directory");
  staging_ = tmpl;
}

OutputSet::~OutputSet() {
  if (committed_) return;
  std::error_code ec;
  fs::remove_all(staging_, ec);
}

std::string OutputSet::stagedPath(const std::string& name) {
  if (!isPlainName(name))
    throw std::invalid_argument("output file name '" + name + "' is not a plain file name");
  if (std::find(names_.begin(), names_.end(), name) == names_.end()) names_.push_back(name);
  return (fs::path(staging_) / name).string();
}

void OutputSet::writeText(const std::string& name, const std::string& text) {
  const std::string path = stagedPath(name);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  out.flush();
  if (!out) fail(path, "writing");
}

void OutputSet::commit() {
  if (committed_) throw std::logic_error("OutputSet::commit called twice");
  for (const std::string& name : names_) fsyncPath((fs::path(staging_) / name).string(), O_RDONLY);
  const std::string marker = (fs::path(dir_) / kMarker).string();
  // The previous set's files, as its marker lists them (a file of the old set that the new
  // one does not write must not stay beside it).
  std::vector<std::string> previous;
  {
    std::ifstream in(marker);
    for (std::string name; std::getline(in, name);)
      if (isPlainName(name)) previous.push_back(name);
  }
  if (::unlink(marker.c_str()) != 0 && errno != ENOENT) fail(marker, "removing the old marker");
  fsyncPath(dir_, O_RDONLY | O_DIRECTORY);
  std::string listing;
  for (const std::string& name : names_) {
    const std::string to = (fs::path(dir_) / name).string();
    if (::rename((fs::path(staging_) / name).c_str(), to.c_str()) != 0) fail(to, "rename");
    listing += name + "\n";
  }
  for (const std::string& name : previous) {
    if (std::find(names_.begin(), names_.end(), name) != names_.end()) continue;
    const std::string old = (fs::path(dir_) / name).string();
    if (::unlink(old.c_str()) != 0 && errno != ENOENT) fail(old, "removing the previous set's file");
  }
  const std::string staged_marker = (fs::path(staging_) / kMarker).string();
  {
    std::ofstream out(staged_marker, std::ios::binary | std::ios::trunc);
    out << listing;
    out.flush();
    if (!out) fail(staged_marker, "writing");
  }
  fsyncPath(staged_marker, O_RDONLY);
  if (::rename(staged_marker.c_str(), marker.c_str()) != 0) fail(marker, "rename");
  fsyncPath(dir_, O_RDONLY | O_DIRECTORY);
  committed_ = true;
  std::error_code ec;
  fs::remove(staging_, ec);
}

}  // namespace novelty_detection
