// libFuzzer target: arbitrary bytes as a .pcd or .ply file through loadCloudFile().
// The first byte picks the extension; the rest is the file. Any outcome other than a
// loaded cloud or a std::runtime_error (crash, hang, other exception) is a finding.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>

#include "novelty_detection/io/cloud_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  static const std::string base = "/tmp/novelty_fuzz_" + std::to_string(::getpid());
  const std::string path = base + ((data[0] & 1) ? ".ply" : ".pcd");
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) return 0;
  std::fwrite(data + 1, 1, size - 1, f);
  std::fclose(f);
  try {
    const novelty_detection::CloudFile cf = novelty_detection::loadCloudFile(path);
    volatile std::size_t n = cf.cloud.size();
    (void)n;
  } catch (const std::runtime_error&) {
  }
  std::remove(path.c_str());
  return 0;
}
