#include "novelty_detection/io/reference_sweeps.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <system_error>

namespace novelty_detection {
namespace fs = std::filesystem;
namespace {

/// The *.pcd entries of `dir`, sorted by name (hidden files skipped).
std::vector<std::string> sweepFiles(const std::string& dir) {
  std::vector<std::string> files;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.empty() || name[0] == '.' || !hasPcdExtension(name)) continue;
    files.push_back(it->path().string());
  }
  if (ec) throw std::runtime_error("cannot read '" + dir + "': " + ec.message());
  std::sort(files.begin(), files.end());
  return files;
}

/// True when `dir` holds nothing but sweep_*.pcd files.
bool onlySweeps(const std::string& dir) {
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.rfind("sweep_", 0) != 0 || !hasPcdExtension(name) || !it->is_regular_file())
      return false;
  }
  return !ec;
}

void removeSweepDir(const std::string& dir) {
  std::error_code ec;
  fs::remove_all(dir, ec);  // best effort: only ever a directory this file wrote
}

void syncDirectory(const std::string& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
  if (fd < 0) return;
  ::fsync(fd);  // best effort (some filesystems refuse)
  ::close(fd);
}

}  // namespace

bool hasPcdExtension(const std::string& path) {
  if (path.size() < 5) return false;
  std::string ext = path.substr(path.size() - 4);
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".pcd";
}

bool isDirectory(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

ReferenceMap loadReference(const std::string& path, const LoadLimits& limits) {
  ReferenceMap map;
  if (!isDirectory(path)) {
    CloudFile file = loadCloudFile(path, limits);
    map.cloud = std::move(file.cloud);
    map.files.push_back(path);
    return map;
  }
  map.files = sweepFiles(path);
  if (map.files.empty())
    throw std::runtime_error("cannot read '" + path + "': a directory without *.pcd sweeps");
  if (map.files.size() > kMaxReferenceSweeps) {
    throw std::runtime_error("cannot read '" + path + "': " + std::to_string(map.files.size()) +
                             " sweeps, more than a reference holds (" +
                             std::to_string(kMaxReferenceSweeps) + ")");
  }
  for (std::size_t k = 0; k < map.files.size(); ++k) {
    LoadLimits left = limits;
    left.max_points =
        limits.max_points - std::min<std::uint64_t>(limits.max_points, map.cloud.size());
    const CloudFile sweep = loadCloudFile(map.files[k], left);
    map.views.origins.push_back(sweep.T_frame_sensor.translation().cast<float>());
    map.cloud.points.insert(map.cloud.points.end(), sweep.cloud.points.begin(),
                            sweep.cloud.points.end());
    map.views.sweep.insert(map.views.sweep.end(), sweep.cloud.size(),
                           static_cast<std::uint32_t>(k));
  }
  map.cloud.width = static_cast<std::uint32_t>(map.cloud.points.size());
  map.cloud.height = 1;
  map.cloud.is_dense = false;
  // One sweep is also a cloud with one stated origin (the single-origin rules apply).
  if (map.views.origins.size() == 1) setSensorOrigin(map.cloud, map.views.origins[0]);
  return map;
}

void saveReferenceSweeps(const std::string& dir, const std::vector<CloudFile>& sweeps) {
  auto fail = [&](const std::string& what) {
    throw std::runtime_error("cannot write '" + dir + "': " + what);
  };
  if (sweeps.empty()) fail("no sweep to save");
  if (sweeps.size() > kMaxReferenceSweeps) fail("more sweeps than a reference holds");
  std::string trimmed = dir;
  while (trimmed.size() > 1 && trimmed.back() == '/') trimmed.pop_back();
  const std::size_t slash = trimmed.find_last_of('/');
  const std::string parent =
      slash == std::string::npos ? "." : (slash == 0 ? "/" : trimmed.substr(0, slash));
  const std::string base = slash == std::string::npos ? trimmed : trimmed.substr(slash + 1);
  if (base.empty() || base == "." || base == "..") fail("no directory name");
  struct stat st {};
  const bool exists = ::lstat(trimmed.c_str(), &st) == 0;
  if (exists && !S_ISDIR(st.st_mode)) fail("it exists and is not a directory");
  if (exists && !onlySweeps(trimmed))
    fail("it holds files other than sweep_*.pcd; not replacing it");

  std::string fresh = parent + "/." + base + ".XXXXXX";
  if (!::mkdtemp(fresh.data()))
    fail("cannot create a directory in '" + parent + "': " + std::strerror(errno));
  try {
    for (std::size_t k = 0; k < sweeps.size(); ++k) {
      char name[32];
      std::snprintf(name, sizeof name, "/sweep_%04zu.pcd", k);
      saveCloudAtomic(fresh + name, sweeps[k].cloud, sweeps[k].T_frame_sensor);
    }
    // mkdtemp makes it private (0700); a reference is as readable as a saved file.
    const mode_t mask = ::umask(0);
    ::umask(mask);
    ::chmod(fresh.c_str(), 0777 & ~mask);
  } catch (...) {
    removeSweepDir(fresh);
    throw;
  }
  std::string old;
  if (exists) {
    // Set the previous reference aside (renaming over an empty directory), then put the new
    // one in its place; on failure the previous one goes back.
    old = parent + "/." + base + ".old.XXXXXX";
    if (!::mkdtemp(old.data()) || std::rename(trimmed.c_str(), old.c_str()) != 0) {
      const int err = errno;
      if (!old.empty()) ::rmdir(old.c_str());
      removeSweepDir(fresh);
      fail(std::string("cannot set the previous reference aside: ") + std::strerror(err));
    }
  }
  if (std::rename(fresh.c_str(), trimmed.c_str()) != 0) {
    const int err = errno;
    if (exists) std::rename(old.c_str(), trimmed.c_str());
    removeSweepDir(fresh);
    fail(std::string("rename failed: ") + std::strerror(err));
  }
  syncDirectory(parent);
  if (exists) removeSweepDir(old);
}

}  // namespace novelty_detection
