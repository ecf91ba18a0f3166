#include "io/pcd_reader.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace novelty_detection {
namespace detail {
namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw std::runtime_error("cannot read '" + path + "': " + what);
}

struct PcdField {
  std::string name;
  int size = 0;                  ///< bytes of one element
  char type = 'F';               ///< F, I or U
  int count = 1;                 ///< elements
  std::size_t byte_offset = 0;   ///< within one binary point
  std::size_t value_offset = 0;  ///< within one ascii line
};

struct PcdHeader {
  std::vector<PcdField> fields;
  std::uint64_t width = 0, height = 1, points = 0;
  std::size_t point_step = 0;                   ///< bytes of one point
  std::size_t values_per_point = 0;             ///< numbers on one ascii line
  double viewpoint[7] = {0, 0, 0, 1, 0, 0, 0};  ///< tx ty tz qw qx qy qz
  std::string data;
  std::uintmax_t header_bytes = 0;
};

long long parseInteger(const std::string& path, const std::string& text, const char* what,
                       long long max_value) {
  std::size_t used = 0;
  long long v = -1;
  try {
    v = std::stoll(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size() || v < 0 || v > max_value) {
    fail(path, std::string("malformed pcd header (bad ") + what + ")");
  }
  return v;
}

PcdHeader parseHeader(const std::string& path, std::istream& in) {
  PcdHeader h;
  std::vector<std::string> names, sizes, types, counts;
  long long width = -1, height = -1, points = -1;
  std::set<std::string> seen;
  std::string line;
  int lines = 0;
  constexpr long long kMaxCount = 1LL << 40;  // points; far beyond any sweep or map
  constexpr long long kMaxSide = std::numeric_limits<std::uint32_t>::max();
  while (std::getline(in, line)) {
    h.header_bytes += line.size() + (in.eof() ? 0 : 1);
    if (++lines > 64 || h.header_bytes > 65536) fail(path, "malformed pcd header (too long)");
    if (!line.empty() && line.back() == '\r') line.pop_back();
    for (char c : line) {
      const auto u = static_cast<unsigned char>(c);
      if (u != '\t' && (u < 32 || u > 126)) fail(path, "malformed pcd header (control byte)");
    }
    if (line.empty() || line[0] == ' ' || line[0] == '\t') {
      fail(path, "malformed pcd header (blank line)");
    }
    if (line[0] == '#') continue;
    std::istringstream ls(line);
    std::string key;
    ls >> key;
    std::vector<std::string> values;
    for (std::string v; ls >> v;) values.push_back(v);
    const std::string canonical = key == "COLUMNS" ? "FIELDS" : key;
    if (!seen.insert(canonical).second) {
      fail(path, "malformed pcd header (" + canonical.substr(0, 32) + " declared twice)");
    }
    auto single = [&](const char* what) -> const std::string& {
      if (values.size() != 1) fail(path, std::string("malformed pcd header (bad ") + what + ")");
      return values[0];
    };
    if (key == "VERSION") continue;
    if (key == "VIEWPOINT") {
      if (values.size() != 7) fail(path, "malformed pcd header (VIEWPOINT needs 7 numbers)");
      for (int i = 0; i < 7; ++i) {
        char* end = nullptr;
        h.viewpoint[i] = std::strtod(values[i].c_str(), &end);
        if (end == values[i].c_str() || *end != '\0' || !std::isfinite(h.viewpoint[i])) {
          fail(path, "malformed pcd header (bad VIEWPOINT)");
        }
      }
    } else if (key == "FIELDS" || key == "COLUMNS") {
      names = values;
    } else if (key == "SIZE") {
      sizes = values;
    } else if (key == "TYPE") {
      types = values;
    } else if (key == "COUNT") {
      counts = values;
    } else if (key == "WIDTH") {
      width = parseInteger(path, single("WIDTH"), "WIDTH", kMaxSide);
    } else if (key == "HEIGHT") {
      height = parseInteger(path, single("HEIGHT"), "HEIGHT", kMaxSide);
    } else if (key == "POINTS") {
      points = parseInteger(path, single("POINTS"), "POINTS", kMaxCount);
    } else if (key == "DATA") {
      h.data = single("DATA");
      break;
    } else {
      fail(path, "malformed pcd header (unknown line '" + key.substr(0, 32) + "')");
    }
  }
  if (h.data.empty()) fail(path, "malformed pcd header (no DATA line)");
  if (h.data != "ascii" && h.data != "binary" && h.data != "binary_compressed") {
    fail(path, "malformed pcd header (unknown DATA '" + h.data.substr(0, 32) + "')");
  }
  if (names.empty() || sizes.size() != names.size() || types.size() != names.size() ||
      (!counts.empty() && counts.size() != names.size())) {
    fail(path, "malformed pcd header (FIELDS, SIZE, TYPE and COUNT disagree)");
  }
  if (width < 0) fail(path, "malformed pcd header (no WIDTH)");
  if (height < 0) height = 1;
  if (points < 0) points = width * height;
  if (width > 0 && height > kMaxCount / width) fail(path, "malformed pcd header (too many points)");
  if (width * height != points) fail(path, "malformed pcd header (WIDTH * HEIGHT != POINTS)");
  h.width = static_cast<std::uint64_t>(width);
  h.height = static_cast<std::uint64_t>(height);
  h.points = static_cast<std::uint64_t>(points);
  for (std::size_t i = 0; i < names.size(); ++i) {
    PcdField f;
    f.name = names[i];
    const std::string& sz = sizes[i];
    if (sz != "1" && sz != "2" && sz != "4" && sz != "8") fail(path, "malformed pcd header (SIZE)");
    f.size = sz[0] - '0';
    const std::string& t = types[i];
    if (t != "F" && t != "I" && t != "U") fail(path, "malformed pcd header (TYPE)");
    f.type = t[0];
    if (f.type == 'F' && f.size != 4 && f.size != 8) {
      fail(path, "malformed pcd header (SIZE of a float)");
    }
    if (!counts.empty())
      f.count = static_cast<int>(parseInteger(path, counts[i], "COUNT", 1 << 20));
    if (f.count < 1) fail(path, "malformed pcd header (bad COUNT)");
    for (const PcdField& other : h.fields)
      if (other.name == f.name && f.name != "_")  // "_": PCL's padding, repeated by design
        fail(path, "malformed pcd header (field '" + f.name.substr(0, 32) + "' given twice)");
    f.byte_offset = h.point_step;
    f.value_offset = h.values_per_point;
    h.point_step += static_cast<std::size_t>(f.size) * static_cast<std::size_t>(f.count);
    h.values_per_point += static_cast<std::size_t>(f.count);
    h.fields.push_back(f);
  }
  return h;
}

/// The x, y, z fields; each must be a float of 4 or 8 bytes.
std::vector<const PcdField*> coordinateFields(const std::string& path, const PcdHeader& h) {
  std::vector<const PcdField*> xyz;
  for (const char* name : {"x", "y", "z"}) {
    const auto it = std::find_if(h.fields.begin(), h.fields.end(),
                                 [&](const PcdField& f) { return f.name == name; });
    if (it == h.fields.end() || it->type != 'F') fail(path, "it has no float x, y, z fields");
    xyz.push_back(&*it);
  }
  return xyz;
}

float readFloat(const unsigned char* p, int size) {
  if (size == 4) {
    float v;
    std::memcpy(&v, p, 4);
    return v;
  }
  double v;
  std::memcpy(&v, p, 8);
  return static_cast<float>(v);
}

void readAscii(const std::string& path, std::istream& in, const PcdHeader& h,
               const std::vector<const PcdField*>& xyz, Cloud& cloud) {
  std::uint64_t rows = 0;
  std::string row;
  std::vector<double> values(h.values_per_point);
  while (std::getline(in, row)) {
    if (!row.empty() && row.back() == '\r') row.pop_back();
    const char* p = row.c_str();
    std::size_t n = 0;
    while (true) {
      while (*p == ' ' || *p == '\t') ++p;
      if (*p == '\0') break;
      const char* start = p;
      while (*p != '\0' && *p != ' ' && *p != '\t') ++p;
      const std::string token(start, p);
      for (char c : token) {
        const auto u = static_cast<unsigned char>(c);
        if (u < 32 || u > 126) fail(path, "malformed ascii pcd file (binary bytes in its data)");
      }
      char* end = nullptr;
      const double v = std::strtod(token.c_str(), &end);
      if (end == token.c_str() || *end != '\0') {
        fail(path, "malformed ascii pcd file (non-numeric value on data line " +
                       std::to_string(rows + 1) + ")");
      }
      if (n < values.size()) values[n] = v;
      ++n;
    }
    if (n == 0) continue;
    if (n != h.values_per_point) {
      fail(path, "malformed ascii pcd file (data line " + std::to_string(rows + 1) + " has " +
                     std::to_string(n) + " values, the header declares " +
                     std::to_string(h.values_per_point) + ")");
    }
    if (++rows > h.points) fail(path, "malformed ascii pcd file (more data lines than POINTS)");
    cloud.push_back(PointT(static_cast<float>(values[xyz[0]->value_offset]),
                           static_cast<float>(values[xyz[1]->value_offset]),
                           static_cast<float>(values[xyz[2]->value_offset])));
  }
  if (rows < h.points) {
    fail(path, "truncated ascii pcd file (" + std::to_string(rows) + " of " +
                   std::to_string(h.points) + " points)");
  }
}

/// Receives decoded body bytes in order: (bytes, count, offset of the first in the body).
using ByteSink = std::function<void(const unsigned char*, std::size_t, std::uint64_t)>;

/// LZF (liblzf's format, used by PCL's binary_compressed): literal runs (ctrl < 32: ctrl + 1
/// bytes follow) and back references (length ctrl >> 5, +7 extension byte, offset 13 bits,
/// so at most 8192 bytes back). Decodes as a stream: only the last 8 KiB of output and one
/// chunk are held, the rest goes to `sink`, so memory does not grow with the expanded size.
/// Every read and write is bounds-checked; returns false on any inconsistency.
bool lzfDecompress(const unsigned char* in, std::size_t in_size, std::uint64_t out_size,
                   const ByteSink& sink) {
  constexpr std::size_t kHistory = 8192, kChunk = 1u << 20, kMaxRun = 7 + 255 + 2;
  std::vector<unsigned char> buf(kHistory + kChunk + kMaxRun);
  std::uint64_t base = 0, emitted = 0;  // body offsets of buf[0] and of the next byte to emit
  std::size_t pos = 0;                  // bytes in buf
  auto flush = [&] {
    sink(buf.data() + (emitted - base), static_cast<std::size_t>(base + pos - emitted), emitted);
    emitted = base + pos;
    const std::size_t keep = std::min(pos, kHistory);
    std::memmove(buf.data(), buf.data() + pos - keep, keep);
    base += pos - keep;
    pos = keep;
  };
  std::size_t ip = 0;
  while (ip < in_size) {
    const unsigned ctrl = in[ip++];
    if (pos + kMaxRun > buf.size()) flush();
    if (ctrl < 32) {
      const std::size_t len = ctrl + 1;
      if (ip + len > in_size || base + pos + len > out_size) return false;
      std::memcpy(buf.data() + pos, in + ip, len);
      ip += len;
      pos += len;
    } else {
      std::size_t len = ctrl >> 5;
      if (len == 7) {
        if (ip >= in_size) return false;
        len += in[ip++];
      }
      if (ip >= in_size) return false;
      const std::size_t back = ((ctrl & 0x1f) << 8) + in[ip++] + 1;
      len += 2;
      if (back > pos || base + pos + len > out_size) return false;
      for (std::size_t k = 0; k < len; ++k, ++pos) buf[pos] = buf[pos - back];  // may overlap
    }
  }
  flush();
  return base + pos == out_size;
}

std::vector<unsigned char> readBytes(const std::string& path, std::istream& in, std::size_t n,
                                     const char* what) {
  std::vector<unsigned char> buf(n);
  if (n > 0 && !in.read(reinterpret_cast<char*>(buf.data()), static_cast<std::streamsize>(n))) {
    fail(path, what);
  }
  return buf;
}

/// Collects one coordinate field (its first element per point) from a stream of body bytes
/// laid out field after field (binary_compressed) or point after point (binary).
struct CoordinateSink {
  std::uint64_t start = 0;   ///< body offset of point 0's value
  std::uint64_t stride = 0;  ///< bytes from one point's value to the next
  std::size_t size = 4;      ///< bytes of the value
  std::vector<unsigned char> bytes;  ///< points x size

  void take(const unsigned char* data, std::size_t n, std::uint64_t offset) {
    const std::uint64_t points = bytes.size() / size;
    if (points == 0 || offset + n <= start) return;
    const std::uint64_t lo = std::max<std::uint64_t>(offset, start), hi = offset + n;
    for (std::uint64_t i = (lo - start) / stride; i < points; ++i) {
      const std::uint64_t v0 = start + i * stride;  // the value's first byte
      if (v0 >= hi) break;
      const std::uint64_t a = std::max(v0, lo), b = std::min<std::uint64_t>(v0 + size, hi);
      if (a < b) std::memcpy(&bytes[i * size + (a - v0)], data + (a - offset), b - a);
    }
  }
  float at(std::uint64_t i) const { return readFloat(&bytes[i * size], static_cast<int>(size)); }
};

}  // namespace

CloudFile readPcdFile(const std::string& path, std::uintmax_t file_size,
                      const LoadLimits& limits) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot open");
  const PcdHeader h = parseHeader(path, in);
  const std::vector<const PcdField*> xyz = coordinateFields(path, h);
  // The limits, from the header alone, before anything the size of the body is allocated.
  if (h.points > limits.max_points) {
    fail(path, std::to_string(h.points) + " points, more than " + limits.parameter + " = " +
                   std::to_string(limits.max_points));
  }
  if (static_cast<unsigned __int128>(h.points) * h.point_step >
      static_cast<unsigned __int128>(limits.max_points) * LoadLimits::kBytesPerPoint) {
    fail(path, std::to_string(h.points) + " points of " + std::to_string(h.point_step) +
                   " bytes, more data than " + std::to_string(LoadLimits::kBytesPerPoint) +
                   " bytes for each of " + limits.parameter + " = " +
                   std::to_string(limits.max_points) + " points");
  }
  const std::uintmax_t body = file_size - std::min(file_size, h.header_bytes);

  CloudFile out;
  Cloud& cloud = out.cloud;
  if (h.data == "ascii") {
    // Every point takes at least two bytes of text; more declared points cannot be there.
    if (h.points > body / 2 + 1) {
      fail(path, "truncated ascii pcd file (" + std::to_string(h.points) +
                     " points declared in a " + std::to_string(body) + "-byte body)");
    }
    cloud.reserve(h.points);
    readAscii(path, in, h, xyz, cloud);
  } else {
    const unsigned __int128 need128 =
        static_cast<unsigned __int128>(h.points) * static_cast<unsigned __int128>(h.point_step);
    if (need128 > body && h.data == "binary") {
      fail(path, "truncated binary pcd file (data shorter than its header declares)");
    }
    const auto need = static_cast<std::uint64_t>(need128);  // <= 1e8 points x 256 bytes
    // Only x, y and z are kept, each gathered straight from the body as it is read.
    CoordinateSink coords[3];
    for (int c = 0; c < 3; ++c) {
      const PcdField& f = *xyz[c];
      coords[c].size = static_cast<std::size_t>(f.size);
      coords[c].bytes.assign(static_cast<std::size_t>(h.points) * coords[c].size, 0);
      if (h.data == "binary") {
        coords[c].start = f.byte_offset;
        coords[c].stride = h.point_step;
      } else {  // compressed bodies store each field for all points in turn (x x x ... y y y)
        std::uint64_t field_start = 0;
        for (const PcdField& g : h.fields) {
          if (&g == &f) break;
          field_start += h.points * static_cast<std::uint64_t>(g.size) * g.count;
        }
        coords[c].start = field_start;
        coords[c].stride = static_cast<std::uint64_t>(f.size) * f.count;
      }
    }
    const ByteSink sink = [&](const unsigned char* data, std::size_t n, std::uint64_t offset) {
      for (CoordinateSink& c : coords) c.take(data, n, offset);
    };
    if (h.data == "binary") {
      std::vector<unsigned char> chunk(std::min<std::uint64_t>(need, 1u << 20));
      for (std::uint64_t offset = 0; offset < need; offset += chunk.size()) {
        const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(chunk.size(), need - offset));
        if (!in.read(reinterpret_cast<char*>(chunk.data()), static_cast<std::streamsize>(n))) {
          fail(path, "truncated binary pcd file (data shorter than its header declares)");
        }
        sink(chunk.data(), n, offset);
      }
    } else {
      if (body < 8) fail(path, "truncated compressed pcd file");
      std::uint32_t sizes[2];
      in.read(reinterpret_cast<char*>(sizes), 8);
      if (!in) fail(path, "truncated compressed pcd file");
      const std::uint32_t compressed = sizes[0], uncompressed = sizes[1];
      if (compressed > body - 8) fail(path, "truncated compressed pcd file");
      if (uncompressed != need) {
        fail(path, "corrupt compressed pcd file (expands to " + std::to_string(uncompressed) +
                       " bytes, the header declares " + std::to_string(need) + ")");
      }
      // LZF expands by at most ~ 264 / 2 bytes per input byte: a larger claim is corrupt.
      if (uncompressed > 140ull * compressed + 64) fail(path, "corrupt compressed pcd file");
      const std::vector<unsigned char> packed =
          readBytes(path, in, compressed, "truncated compressed pcd file");
      if (uncompressed > 0 && !lzfDecompress(packed.data(), packed.size(), uncompressed, sink)) {
        fail(path, "corrupt compressed pcd file (bad LZF data)");
      }
    }
    cloud.resize(h.points);
    for (std::uint64_t i = 0; i < h.points; ++i) {
      cloud[i].x = coords[0].at(i);
      cloud[i].y = coords[1].at(i);
      cloud[i].z = coords[2].at(i);
    }
  }
  cloud.width = static_cast<std::uint32_t>(h.width);
  cloud.height = static_cast<std::uint32_t>(h.height);
  cloud.is_dense = std::all_of(cloud.begin(), cloud.end(), [](const PointT& p) {
    return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
  });
  Eigen::Quaterniond q(h.viewpoint[3], h.viewpoint[4], h.viewpoint[5], h.viewpoint[6]);
  out.T_frame_sensor.linear() =
      q.norm() > 0.5 ? q.normalized().toRotationMatrix() : Eigen::Matrix3d::Identity();
  out.T_frame_sensor.translation() =
      Eigen::Vector3d(h.viewpoint[0], h.viewpoint[1], h.viewpoint[2]);
  return out;
}

}  // namespace detail
}  // namespace novelty_detection
