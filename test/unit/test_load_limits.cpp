// Load-time limits: a file's header is checked against preprocess/max_points before its body
// is read, and a compressed body is decoded as a stream, so a small file cannot claim
// gigabytes. The CLI cases run novelty_detect as a child and read its peak memory.
#include <gtest/gtest.h>

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "novelty_detection/io/cloud_io.h"

namespace fs = std::filesystem;
using namespace novelty_detection;

namespace {

/// A fresh directory, removed with what it holds (files of up to 50 MB) at scope exit.
struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& name)
      : path(fs::temp_directory_path() /
             ("novelty_limits_" + name + "_" + std::to_string(::getpid()))) {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  operator const fs::path&() const { return path; }
  fs::path operator/(const std::string& name) const { return path / name; }
};

/// LZF: `n` zero bytes as one literal then back references of 264 bytes (88:1).
std::vector<unsigned char> lzfZeros(std::uint64_t n) {
  std::vector<unsigned char> out = {0, 0};  // a literal run of one zero byte
  std::uint64_t done = 1;
  while (done < n) {
    const std::uint64_t len = std::min<std::uint64_t>(264, n - done);
    if (len < 3) {  // a short literal tail
      out.push_back(static_cast<unsigned char>(len - 1));
      for (std::uint64_t k = 0; k < len; ++k) out.push_back(0);
    } else if (len - 2 < 7) {
      out.push_back(static_cast<unsigned char>(((len - 2) << 5) | 0));
      out.push_back(0);  // back 1
    } else {
      out.push_back(static_cast<unsigned char>((7 << 5) | 0));
      out.push_back(static_cast<unsigned char>(len - 2 - 7));
      out.push_back(0);
    }
    done += len;
  }
  return out;
}

/// LZF: `data` as literal runs of 32 bytes (no compression, always valid).
std::vector<unsigned char> lzfLiterals(const std::vector<unsigned char>& data) {
  std::vector<unsigned char> out;
  out.reserve(data.size() + data.size() / 32 + 1);
  for (std::size_t i = 0; i < data.size(); i += 32) {
    const std::size_t len = std::min<std::size_t>(32, data.size() - i);
    out.push_back(static_cast<unsigned char>(len - 1));
    out.insert(out.end(), data.begin() + i, data.begin() + i + len);
  }
  return out;
}

std::string header(const std::string& fields, const std::string& sizes, const std::string& types,
                   const std::string& counts, std::uint64_t points, const std::string& data) {
  std::ostringstream h;
  h << "VERSION .7\nFIELDS " << fields << "\nSIZE " << sizes << "\nTYPE " << types << "\nCOUNT "
    << counts << "\nWIDTH " << points << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\n"
    << "POINTS " << points << "\nDATA " << data << "\n";
  return h.str();
}

void writeCompressed(const fs::path& path, const std::string& head,
                     const std::vector<unsigned char>& packed, std::uint32_t uncompressed) {
  std::ofstream out(path, std::ios::binary);
  out << head;
  const std::uint32_t sizes[2] = {static_cast<std::uint32_t>(packed.size()), uncompressed};
  out.write(reinterpret_cast<const char*>(sizes), 8);
  out.write(reinterpret_cast<const char*>(packed.data()),
            static_cast<std::streamsize>(packed.size()));
}

std::string errorOf(const fs::path& path, const LoadLimits& limits = {}) {
  try {
    loadCloud(path.string(), limits);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

struct ChildRun {
  int code = -1;
  long max_rss_kb = 0;
  double seconds = 0;
  std::string err;
};

/// novelty_detect with `cur` as the current cloud against a small valid reference; with
/// `config` as --config and at most `address_space_mb` of memory when given.
ChildRun runCli(const fs::path& dir, const fs::path& cur, const fs::path& config = {},
                long address_space_mb = 0) {
  const fs::path ref = dir / "ref.pcd";
  if (!fs::exists(ref)) {
    Cloud c;
    for (int i = 0; i < 100; ++i) c.push_back(PointT(0.01f * i, 0.f, 0.f));
    saveCloudAtomic(ref.string(), c);
  }
  const fs::path err = dir / "stderr.txt";
  const auto t0 = std::chrono::steady_clock::now();
  const pid_t pid = ::fork();
  if (pid == 0) {
    const std::string bin = std::string(NOVELTY_BIN_DIR) + "/novelty_detect";
    if (!std::freopen(err.c_str(), "w", stderr) || !std::freopen("/dev/null", "w", stdout))
      ::_exit(127);
    if (address_space_mb > 0) {
      const rlimit limit{static_cast<rlim_t>(address_space_mb) << 20,
                         static_cast<rlim_t>(address_space_mb) << 20};
      if (::setrlimit(RLIMIT_AS, &limit) != 0) ::_exit(127);
    }
    const std::string out = (dir / "out").string();
    std::vector<std::string> args = {bin,          "--reference", ref.string(), "--current",
                                     cur.string(), "--out",       out};
    if (!config.empty()) args.insert(args.end(), {"--config", config.string()});
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    ::execv(bin.c_str(), argv.data());
    ::_exit(127);
  }
  ChildRun r;
  int status = 0;
  struct rusage usage {};
  if (::wait4(pid, &status, 0, &usage) == pid && WIFEXITED(status)) r.code = WEXITSTATUS(status);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.max_rss_kb = usage.ru_maxrss;
  std::ifstream in(err);
  std::stringstream ss;
  ss << in.rdbuf();
  r.err = ss.str();
  return r;
}

// Under AddressSanitizer freed memory sits in a quarantine (256 MB by default) and every
// byte has shadow memory: the bound grows by that much, still far below the gigabytes an
// unchecked body would take.
#if defined(__SANITIZE_ADDRESS__)
constexpr long kRssBoundKb = (300 + 300) * 1024;
#else
constexpr long kRssBoundKb = 300 * 1024;
#endif

}  // namespace

TEST(LoadLimits, TooManyPointsAreRefusedFromTheHeader) {
  const TempDir dir("points");
  // 20 million zero points in a 2.7 MB file: 240 MB once expanded.
  const std::uint64_t n = 20000000;
  const fs::path path = dir / "huge.pcd";
  writeCompressed(path, header("x y z", "4 4 4", "F F F", "1 1 1", n, "binary_compressed"),
                  lzfZeros(n * 12), static_cast<std::uint32_t>(n * 12));
  EXPECT_LT(fs::file_size(path), 3u << 20);
  LoadLimits limits;
  limits.max_points = 2000000;
  EXPECT_NE(
      errorOf(path, limits).find("20000000 points, more than preprocess/max_points = 2000000"),
      std::string::npos)
      << errorOf(path, limits);

  const ChildRun r = runCli(dir, path);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("more than preprocess/max_points = 2000000"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;  // one line
  EXPECT_LT(r.max_rss_kb, kRssBoundKb) << r.seconds << " s";
}

TEST(LoadLimits, AStreamedCompressedBodyDecodesExactlyWithoutExpandingWhole) {
  // Allowed: 3 million points (72 MB expanded, a 0.8 MB file) with a three-element field
  // between the coordinates, decoded across many chunks of the stream. Every point is 0.
  const TempDir dir("stream");
  const std::uint64_t n = 3000000;
  const fs::path path = dir / "zeros.pcd";
  writeCompressed(path,
                  header("x pad y z", "4 4 4 4", "F F F F", "1 3 1 1", n, "binary_compressed"),
                  lzfZeros(n * 24), static_cast<std::uint32_t>(n * 24));
  LoadLimits limits;
  limits.max_points = n;
  const Cloud c = loadCloud(path.string(), limits);
  ASSERT_EQ(c.size(), n);
  std::size_t zeros = 0;
  for (const auto& p : c) zeros += p.x == 0.f && p.y == 0.f && p.z == 0.f;
  EXPECT_EQ(zeros, n);
}

TEST(LoadLimits, RandomCoordinatesSurviveTheStreamedDecoder) {
  // Literal-only LZF of known random floats, x y z planar, longer than one decoder chunk.
  const TempDir dir("random");
  const std::uint64_t n = 200000;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-50.f, 50.f);
  std::vector<float> values(3 * n);
  for (float& v : values) v = u(rng);
  std::vector<unsigned char> raw(values.size() * 4);
  std::memcpy(raw.data(), values.data(), raw.size());
  const fs::path path = dir / "random.pcd";
  writeCompressed(path, header("x y z", "4 4 4", "F F F", "1 1 1", n, "binary_compressed"),
                  lzfLiterals(raw), static_cast<std::uint32_t>(raw.size()));
  const Cloud c = loadCloud(path.string());
  ASSERT_EQ(c.size(), n);
  for (std::uint64_t i = 0; i < n; i += 997) {
    EXPECT_EQ(c[i].x, values[i]);
    EXPECT_EQ(c[i].y, values[n + i]);
    EXPECT_EQ(c[i].z, values[2 * n + i]);
  }
}

TEST(LoadLimits, WideRecordsAreRefusedFromTheHeader) {
  // 1 million points of 4 KB each: within max_points, but 4 GB of record data.
  const TempDir dir("wide");
  const fs::path path = dir / "wide.pcd";
  writeCompressed(
      path, header("x y z pad", "4 4 4 4", "F F F F", "1 1 1 1021", 1000000, "binary_compressed"),
      lzfZeros(4096), 4096);
  LoadLimits limits;
  limits.max_points = 2000000;
  const std::string e = errorOf(path, limits);
  EXPECT_NE(e.find("1000000 points of 4096 bytes, more data than 256 bytes for each of "
                   "preprocess/max_points = 2000000 points"),
            std::string::npos)
      << e;
}

TEST(LoadLimits, GarbageCompressedBodyIsRefusedWithBoundedMemory) {
  // 2 million declared points (within the limit) and a 48 MB body that decodes as valid
  // literals until its last run is cut: the whole stream is decoded before it fails.
  const TempDir dir("garbage");
  const std::uint64_t n = 2000000;
  std::vector<unsigned char> raw(n * 24);
  std::mt19937 rng(11);
  for (auto& b : raw) b = static_cast<unsigned char>(rng());
  std::vector<unsigned char> packed = lzfLiterals(raw);
  packed.resize(packed.size() - 5);
  const fs::path path = dir / "garbage.pcd";
  writeCompressed(
      path,
      header("x y z w a b", "4 4 4 4 4 4", "F F F F F F", "1 1 1 1 1 1", n, "binary_compressed"),
      packed, static_cast<std::uint32_t>(raw.size()));
  EXPECT_GT(fs::file_size(path), 45u << 20);
  EXPECT_LT(fs::file_size(path), 50u << 20);
  EXPECT_NE(errorOf(path).find("corrupt compressed pcd file (bad LZF data)"), std::string::npos);

  const ChildRun r = runCli(dir, path);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("bad LZF data"), std::string::npos) << r.err;
  EXPECT_LT(r.max_rss_kb, kRssBoundKb) << r.seconds << " s";

  // Random bytes with no header at all.
  const fs::path noise = dir / "noise.pcd";
  {
    std::ofstream out(noise, std::ios::binary);
    out.write(reinterpret_cast<const char*>(raw.data()), static_cast<std::streamsize>(raw.size()));
  }
  const ChildRun q = runCli(dir, noise);
  EXPECT_EQ(q.code, 1);
  EXPECT_NE(q.err.find("noise.pcd"), std::string::npos) << q.err;
  EXPECT_LT(q.max_rss_kb, kRssBoundKb) << q.seconds << " s";
}

TEST(LoadLimits, PlyVertexCountIsCheckedAgainstTheLimit) {
  const TempDir dir("ply");
  const fs::path path = dir / "cloud.ply";
  {
    std::ofstream out(path);
    out << "ply\nformat ascii 1.0\nelement vertex 50\nproperty float x\nproperty float y\n"
           "property float z\nend_header\n";
    for (int i = 0; i < 50; ++i) out << i << " 0 0\n";
  }
  EXPECT_EQ(loadCloud(path.string()).size(), 50u);
  LoadLimits limits;
  limits.max_points = 49;
  EXPECT_NE(errorOf(path, limits).find("50 points, more than preprocess/max_points = 49"),
            std::string::npos)
      << errorOf(path, limits);
}

TEST(LoadLimits, OutOfMemoryIsNamedNotLeftToTheStandardLibrary) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "an address-space limit and AddressSanitizer's shadow memory exclude each other";
#endif
  // 10 million points allowed by the configuration, in a process limited to 200 MB.
  const TempDir dir("memory");
  const std::uint64_t n = 10000000;
  const fs::path path = dir / "big.pcd";
  writeCompressed(path, header("x y z", "4 4 4", "F F F", "1 1 1", n, "binary_compressed"),
                  lzfZeros(n * 12), static_cast<std::uint32_t>(n * 12));
  const fs::path config = dir / "config.yaml";
  std::ofstream(config) << "preprocess:\n  max_points: 20000000\n";
  const ChildRun r = runCli(dir, path, config, 200);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("big.pcd': out of memory while loading it"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("lower preprocess/max_points"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("std::bad_alloc"), std::string::npos) << r.err;
}
