#include "novelty_detection/io/reference_cache.h"

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <vector>

#include "novelty_detection/io/params_io.h"

namespace novelty_detection {
namespace {

namespace fs = std::filesystem;

constexpr char kMagic[16] = "NDREFMODEL v1\n";  // zero-padded to 16 bytes
constexpr int kDoublesPerGaussian = 13;         // weight, mean (3), covariance (9)

class Fnv1a {
 public:
  void add(const void* data, std::size_t size) {
    const auto* b = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < size; ++i) {
      h_ ^= b[i];
      h_ *= 1099511628211ull;
    }
  }
  template <class T>
  void addValue(const T& v) {
    add(&v, sizeof v);
  }
  std::uint64_t value() const { return h_; }

 private:
  std::uint64_t h_ = 1469598103934665603ull;
};

struct Header {
  char magic[16];
  char key[16];
  std::uint64_t kept = 0;
  std::uint64_t gaussians = 0;
  double explained_log_density = 0.0;
};

std::size_t bodySize(const Header& h) {
  return h.kept * sizeof(std::int32_t) + h.gaussians * kDoublesPerGaussian * sizeof(double);
}

}  // namespace

std::string referenceCacheKey(const Params& params, const Cloud& reference,
                              const ReferenceViews& views) {
  Params p = params;
  p.compute.threads = 0;  // results do not depend on it
  Fnv1a h;
  h.add(kMagic, sizeof kMagic);
  const std::string yaml = paramsToYaml(p);
  h.add(yaml.data(), yaml.size());
  h.addValue(static_cast<std::uint64_t>(reference.size()));
  for (const PointT& q : reference.points) {
    h.addValue(q.x);
    h.addValue(q.y);
    h.addValue(q.z);
  }
  h.add(reference.sensor_origin_.data(), 4 * sizeof(float));
  h.add(reference.sensor_orientation_.coeffs().data(), 4 * sizeof(float));
  h.addValue(static_cast<std::uint64_t>(views.origins.size()));
  for (const Eigen::Vector3f& o : views.origins) h.add(o.data(), 3 * sizeof(float));
  if (!views.sweep.empty()) h.add(views.sweep.data(), views.sweep.size() * sizeof(std::uint32_t));
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(h.value()));
  return text;
}

std::string referenceCachePath(const std::string& dir, const std::string& key) {
  return (fs::path(dir) / (key + ".refmodel")).string();
}

std::optional<ReferenceModelSummary> loadReferenceSummary(const std::string& dir,
                                                          const std::string& key) {
  const std::string path = referenceCachePath(dir, key);
  std::error_code ec;
  if (!fs::exists(path, ec)) return std::nullopt;
  auto fail = [&](const std::string& why) -> std::runtime_error {
    return std::runtime_error("reference cache '" + path + "': " + why);
  };
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec) throw fail("cannot read its size (" + ec.message() + ")");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw fail("cannot open it");
  Header h;
  if (size < sizeof h + sizeof(std::uint64_t) || !in.read(reinterpret_cast<char*>(&h), sizeof h))
    throw fail("truncated");
  if (std::memcmp(h.magic, kMagic, sizeof kMagic) != 0) throw fail("not a reference model file");
  if (key.size() != sizeof h.key || std::memcmp(h.key, key.data(), sizeof h.key) != 0)
    throw fail("holds the model of another key");
  // The counts are checked against the file's size before anything is allocated.
  constexpr std::uint64_t kMaxCount = std::uint64_t(1) << 31;
  if (h.kept > kMaxCount || h.gaussians > kMaxCount ||
      size != sizeof h + bodySize(h) + sizeof(std::uint64_t))
    throw fail("its size does not match the counts it states");
  std::vector<std::int32_t> kept(h.kept);
  std::vector<double> gaussians(h.gaussians * kDoublesPerGaussian);
  std::uint64_t stored = 0;
  if (!in.read(reinterpret_cast<char*>(kept.data()),
               static_cast<std::streamsize>(kept.size() * sizeof(std::int32_t))) ||
      !in.read(reinterpret_cast<char*>(gaussians.data()),
               static_cast<std::streamsize>(gaussians.size() * sizeof(double))) ||
      !in.read(reinterpret_cast<char*>(&stored), sizeof stored))
    throw fail("truncated");
  Fnv1a check;
  check.add(&h, sizeof h);
  check.add(kept.data(), kept.size() * sizeof(std::int32_t));
  check.add(gaussians.data(), gaussians.size() * sizeof(double));
  if (check.value() != stored) throw fail("checksum mismatch (a damaged file)");
  ReferenceModelSummary s;
  s.kept.assign(kept.begin(), kept.end());
  s.explained_log_density = h.explained_log_density;
  s.gmm.components.resize(h.gaussians);
  for (std::size_t k = 0; k < h.gaussians; ++k) {
    const double* g = gaussians.data() + k * kDoublesPerGaussian;
    Gaussian& c = s.gmm.components[k];
    c.weight = g[0];
    c.mean = Eigen::Map<const Eigen::Vector3d>(g + 1);
    c.cov = Eigen::Map<const Eigen::Matrix3d>(g + 4);
  }
  return s;
}

void saveReferenceSummary(const std::string& dir, const std::string& key,
                          const ReferenceModelSummary& summary) {
  if (key.size() != 16) throw std::runtime_error("reference cache: a key has 16 hex digits");
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec)
    throw std::runtime_error("cannot create the reference cache '" + dir + "': " + ec.message());
  Header h;
  std::memcpy(h.magic, kMagic, sizeof kMagic);
  std::memcpy(h.key, key.data(), sizeof h.key);
  h.kept = summary.kept.size();
  h.gaussians = summary.gmm.size();
  h.explained_log_density = summary.explained_log_density;
  std::vector<std::int32_t> kept(summary.kept.begin(), summary.kept.end());
  std::vector<double> gaussians;
  gaussians.reserve(h.gaussians * kDoublesPerGaussian);
  for (const Gaussian& c : summary.gmm.components) {
    gaussians.push_back(c.weight);
    gaussians.insert(gaussians.end(), c.mean.data(), c.mean.data() + 3);
    gaussians.insert(gaussians.end(), c.cov.data(), c.cov.data() + 9);
  }
  Fnv1a check;
  check.add(&h, sizeof h);
  check.add(kept.data(), kept.size() * sizeof(std::int32_t));
  check.add(gaussians.data(), gaussians.size() * sizeof(double));
  const std::uint64_t sum = check.value();
  const std::string path = referenceCachePath(dir, key);
  const std::string tmp = path + ".tmp-" + std::to_string(::getpid());
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(&h), sizeof h);
    out.write(reinterpret_cast<const char*>(kept.data()),
              static_cast<std::streamsize>(kept.size() * sizeof(std::int32_t)));
    out.write(reinterpret_cast<const char*>(gaussians.data()),
              static_cast<std::streamsize>(gaussians.size() * sizeof(double)));
    out.write(reinterpret_cast<const char*>(&sum), sizeof sum);
    out.close();
    if (!out) {
      fs::remove(tmp, ec);
      throw std::runtime_error("cannot write the reference cache file '" + tmp + "'");
    }
  }
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw std::runtime_error("cannot write the reference cache file '" + path + "'");
  }
}

ReferenceCacheUse setReferenceCached(Pipeline& pipeline, const Cloud& reference,
                                     const ReferenceViews& views, const std::string& dir) {
  ReferenceCacheUse use;
  use.key = referenceCacheKey(pipeline.params(), reference, views);
  std::optional<ReferenceModelSummary> stored;
  try {
    stored = loadReferenceSummary(dir, use.key);
  } catch (const std::runtime_error& e) {
    use.message = e.what();
  }
  if (stored) {
    try {
      pipeline.setReference(reference, views, *stored);
      use.state = "hit";
      return use;
    } catch (const std::invalid_argument& e) {
      use.message = "reference cache '" + referenceCachePath(dir, use.key) + "': " + e.what();
    }
  }
  pipeline.setReference(reference, views);
  use.state = use.message.empty() ? "written" : "replaced";
  try {
    saveReferenceSummary(dir, use.key, pipeline.referenceSummary());
  } catch (const std::runtime_error& e) {
    use.state = "not written";
    use.message += (use.message.empty() ? "" : "; ") + std::string(e.what());
  }
  return use;
}

}  // namespace novelty_detection
