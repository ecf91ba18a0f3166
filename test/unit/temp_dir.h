// A fresh, empty directory for one test: TMP/novelty_<prefix>_<name>_<pid>.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <string>

namespace test_helpers {

inline std::filesystem::path freshTempDir(const std::string& prefix, const std::string& name) {
  const std::filesystem::path d =
      std::filesystem::temp_directory_path() /
      ("novelty_" + prefix + "_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

}  // namespace test_helpers
