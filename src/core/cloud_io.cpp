#include "novelty_detection/cloud_io.h"

#include <pcl/PCLPointCloud2.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>

#include <sys/stat.h>
#include <unistd.h>
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace novelty_detection {
namespace {

std::string lowerExtension(const std::string& path) {
  const auto dot = path.find_last_of('.');
  if (dot == std::string::npos) return "";
  std::string ext = path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw std::runtime_error("cannot read '" + path + "': " + what);
}

bool hasFloatField(const pcl::PCLPointCloud2& msg, const std::string& name) {
  for (const auto& f : msg.fields) {
    if (f.name == name) return f.datatype == pcl::PCLPointField::FLOAT32 && f.count >= 1;
  }
  return false;
}

// PCL's PCD reader trusts its header and crashes on inconsistent ones, so the header is
// checked here first: every declaration present once, per-field lists of equal length,
// WIDTH * HEIGHT == POINTS, known DATA kind, and a body long enough for binary data.
void validatePcdHeader(const std::string& path, std::uintmax_t file_size) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot open");
  std::vector<std::string> fields, sizes, types, counts;
  long long width = -1, height = -1, points = -1;
  std::string data;
  std::string line;
  std::size_t header_bytes = 0;
  std::set<std::string> seen;
  int lines = 0;
  while (std::getline(in, line)) {
    header_bytes += line.size() + 1;
    if (++lines > 64 || header_bytes > 65536) fail(path, "malformed pcd header (too long)");
    if (!line.empty() && line.back() == '\r') line.pop_back();
    // PCL splits header lines on other characters than we do; only plain text lines, each
    // declaration once, are parsed the same way by both.
    for (char c : line) {
      if (c != '\t' && (c < 32 || c > 126)) fail(path, "malformed pcd header (control byte)");
    }
    // PCL's header parser crashes on blank or whitespace-led lines; the format has none.
    if (line.empty() || line[0] == ' ' || line[0] == '\t') {
      fail(path, "malformed pcd header (blank line)");
    }
    if (line[0] == '#') continue;
    std::istringstream ls(line);
    std::string key;
    ls >> key;
    std::vector<std::string> values;
    for (std::string v; ls >> v;) values.push_back(v);
    auto number = [&](const char* what) -> long long {
      if (values.size() != 1) fail(path, std::string("malformed pcd header: bad ") + what);
      try {
        std::size_t used = 0;
        const long long v = std::stoll(values[0], &used);
        if (used != values[0].size() || v < 0) throw std::invalid_argument(what);
        return v;
      } catch (const std::exception&) {
        fail(path, std::string("malformed pcd header: bad ") + what);
      }
    };
    const std::string canonical = key == "COLUMNS" ? "FIELDS" : key;
    if (!seen.insert(canonical).second) {
      fail(path, "malformed pcd header (" + canonical.substr(0, 32) + " declared twice)");
    }
    if (key == "VERSION" || key == "VIEWPOINT") continue;
    if (key == "FIELDS" || key == "COLUMNS")
      fields = values;
    else if (key == "SIZE")
      sizes = values;
    else if (key == "TYPE")
      types = values;
    else if (key == "COUNT")
      counts = values;
    else if (key == "WIDTH")
      width = number("WIDTH");
    else if (key == "HEIGHT")
      height = number("HEIGHT");
    else if (key == "POINTS")
      points = number("POINTS");
    else if (key == "DATA") {
      data = values.empty() ? "" : values[0];
      break;
    } else {
      fail(path, "malformed pcd header (unknown line '" + key.substr(0, 32) + "')");
    }
  }
  if (data.empty()) fail(path, "malformed pcd header (no DATA line)");
  if (data != "ascii" && data != "binary" && data != "binary_compressed") {
    fail(path, "malformed pcd header (unknown DATA '" + data.substr(0, 32) + "')");
  }
  if (fields.empty() || sizes.size() != fields.size() || types.size() != fields.size() ||
      (!counts.empty() && counts.size() != fields.size())) {
    fail(path, "malformed pcd header (FIELDS, SIZE, TYPE and COUNT disagree)");
  }
  if (width < 0) fail(path, "malformed pcd header (no WIDTH)");
  if (height < 0) height = 1;
  if (points < 0) points = width * height;
  if (width * height != points) fail(path, "malformed pcd header (WIDTH * HEIGHT != POINTS)");
  long long point_step = 0;
  long long values_per_point = 0;
  for (std::size_t i = 0; i < fields.size(); ++i) {
    const std::string& sz = sizes[i];
    if (sz != "1" && sz != "2" && sz != "4" && sz != "8") fail(path, "malformed pcd header (SIZE)");
    const std::string& t = types[i];
    if (t != "F" && t != "I" && t != "U") fail(path, "malformed pcd header (TYPE)");
    // PCL maps (TYPE, SIZE) to a datatype; floats exist only as 4 or 8 bytes.
    if (t == "F" && sz != "4" && sz != "8") fail(path, "malformed pcd header (SIZE of a float)");
    long long count = 1;
    if (!counts.empty()) {
      std::size_t used = 0;
      try {
        count = std::stoll(counts[i], &used);
      } catch (const std::exception&) {
        fail(path, "malformed pcd header (COUNT)");
      }
      if (used != counts[i].size() || count < 1 || count > 1 << 20) {
        fail(path, "malformed pcd header (COUNT)");
      }
    }
    point_step += std::stoll(sz) * count;
    values_per_point += count;
  }
  if (data == "binary" &&
      static_cast<std::uintmax_t>(header_bytes) +
              static_cast<std::uintmax_t>(points) * static_cast<std::uintmax_t>(point_step) >
          file_size) {
    fail(path, "truncated binary pcd file (data shorter than its header declares)");
  }
  if (data == "ascii") {
    // PCL's ASCII parser misreads bodies that do not match the header (binary bytes or a
    // stray word made it allocate terabytes), so the body is checked in full: text only,
    // exactly POINTS lines of exactly sum(COUNT) numbers (nan and inf allowed).
    long long rows = 0;
    std::string row;
    while (std::getline(in, row)) {
      if (!row.empty() && row.back() == '\r') row.pop_back();
      for (char c : row) {
        const unsigned char u = static_cast<unsigned char>(c);
        if (u > 126 || (u < 32 && u != '\t')) {
          fail(path, "malformed ascii pcd file (binary bytes in its data)");
        }
      }
      std::istringstream tokens(row);
      long long n = 0;
      for (std::string t; tokens >> t; ++n) {
        char* end = nullptr;
        std::strtod(t.c_str(), &end);
        if (end == t.c_str() || *end != '\0') {
          fail(path, "malformed ascii pcd file (non-numeric value on data line " +
                         std::to_string(rows + 1) + ")");
        }
      }
      if (n == 0) continue;
      if (n != values_per_point) {
        fail(path, "malformed ascii pcd file (data line " + std::to_string(rows + 1) + " has " +
                       std::to_string(n) + " values, the header declares " +
                       std::to_string(values_per_point) + ")");
      }
      if (++rows > points) fail(path, "malformed ascii pcd file (more data lines than POINTS)");
    }
    if (rows < points) {
      fail(path, "truncated ascii pcd file (" + std::to_string(rows) + " of " +
                     std::to_string(points) + " points)");
    }
  }
  if (data == "binary_compressed" && header_bytes + 8 > file_size) {
    fail(path, "truncated compressed pcd file");
  }
}

// The PLY counterpart: PCL allocates element storage from the header's counts before
// reading, so counts must be sane numbers that the file can actually hold.
void validatePlyHeader(const std::string& path, std::uintmax_t file_size) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot open");
  std::string line;
  std::size_t header_bytes = 0;
  int lines = 0;
  bool magic = false, format = false, vertex = false, end = false;
  std::string kind;
  std::uintmax_t min_body_bytes = 0;
  std::uintmax_t current_count = 0;
  bool current_is_list = false;
  while (std::getline(in, line)) {
    header_bytes += line.size() + 1;
    if (++lines > 256 || header_bytes > 65536) fail(path, "malformed ply header (too long)");
    if (!line.empty() && line.back() == '\r') line.pop_back();
    for (char c : line) {
      if (c != '\t' && (c < 32 || c > 126)) fail(path, "malformed ply header (control byte)");
    }
    std::istringstream ls(line);
    std::string key;
    ls >> key;
    if (lines == 1) {
      if (key != "ply") fail(path, "not a ply file (no 'ply' magic)");
      magic = true;
      continue;
    }
    if (key == "format") {
      ls >> kind;
      if (kind != "ascii" && kind != "binary_little_endian" && kind != "binary_big_endian") {
        fail(path, "malformed ply header (unknown format)");
      }
      format = true;
    } else if (key == "element") {
      std::string name, count;
      ls >> name >> count;
      std::size_t used = 0;
      long long n = -1;
      try {
        n = std::stoll(count, &used);
      } catch (const std::exception&) {
      }
      if (n < 0 || used != count.size() || static_cast<std::uintmax_t>(n) > file_size) {
        fail(path, "malformed ply header (element count '" + count.substr(0, 32) + "')");
      }
      if (name == "vertex") vertex = true;
      current_count = static_cast<std::uintmax_t>(n);
      current_is_list = false;
    } else if (key == "property") {
      std::string type;
      ls >> type;
      if (type == "list") current_is_list = true;
      // Every property of every element takes at least one byte (binary) or char (ascii).
      if (!current_is_list) min_body_bytes += current_count;
    } else if (key == "end_header") {
      end = true;
      break;
    }
  }
  if (!magic || !format || !end) fail(path, "malformed ply header");
  if (!vertex) fail(path, "ply file has no vertex element");
  if (header_bytes + min_body_bytes > file_size) {
    fail(path, "truncated ply file (body shorter than its header declares)");
  }
}

}  // namespace

CloudFile loadCloudFile(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) fail(path, "no such file");
  if (!S_ISREG(st.st_mode)) fail(path, "not a regular file");
  if (::access(path.c_str(), R_OK) != 0) fail(path, "permission denied");
  if (st.st_size == 0) fail(path, "empty file");

  const std::string ext = lowerExtension(path);
  pcl::PCLPointCloud2 blob;
  Eigen::Vector4f origin = Eigen::Vector4f::Zero();
  Eigen::Quaternionf orientation = Eigen::Quaternionf::Identity();
  int rc = -1;
  try {
    if (ext == "pcd") {
      validatePcdHeader(path, static_cast<std::uintmax_t>(st.st_size));
      pcl::PCDReader reader;
      int version = 0;
      rc = reader.read(path, blob, origin, orientation, version);
    } else if (ext == "ply") {
      validatePlyHeader(path, static_cast<std::uintmax_t>(st.st_size));
      pcl::PLYReader reader;
      int version = 0;
      rc = reader.read(path, blob, origin, orientation, version);
    } else {
      fail(path, "unknown extension '." + ext + "' (expected .pcd or .ply)");
    }
  } catch (const std::runtime_error&) {
    throw;
  } catch (const std::exception& e) {
    fail(path, e.what());
  }
  if (rc < 0) fail(path, "malformed or truncated " + ext + " file");
  if (!hasFloatField(blob, "x") || !hasFloatField(blob, "y") || !hasFloatField(blob, "z")) {
    fail(path, "it has no float32 x, y, z fields");
  }
  const std::size_t expected = static_cast<std::size_t>(blob.width) * blob.height * blob.point_step;
  if (blob.data.size() < expected) fail(path, "data shorter than its header declares");

  CloudFile out;
  // An empty cloud is valid; PCL's conversion would index its empty buffers.
  if (blob.width * blob.height > 0) pcl::fromPCLPointCloud2(blob, out.cloud);
  const Eigen::Quaterniond q = orientation.cast<double>();
  out.T_frame_sensor.linear() =
      q.norm() > 0.5 ? q.normalized().toRotationMatrix() : Eigen::Matrix3d::Identity();
  out.T_frame_sensor.translation() = origin.head<3>().cast<double>();
  // Keep the viewpoint on the cloud too, as PCL does, for code that reads it from there.
  out.cloud.sensor_origin_ = Eigen::Vector4f(origin[0], origin[1], origin[2], 0.f);
  out.cloud.sensor_orientation_ = Eigen::Quaternionf(out.T_frame_sensor.linear().cast<float>());
  return out;
}

Cloud loadCloud(const std::string& path) { return loadCloudFile(path).cloud; }

void saveCloudAtomic(const std::string& path, const Cloud& cloud,
                     const Eigen::Isometry3d& T_frame_sensor) {
  Cloud copy = cloud;
  copy.sensor_origin_.head<3>() = T_frame_sensor.translation().cast<float>();
  copy.sensor_origin_[3] = 0.f;
  copy.sensor_orientation_ = Eigen::Quaternionf(T_frame_sensor.linear().cast<float>());
  if (copy.width * copy.height != copy.size()) {
    copy.width = static_cast<std::uint32_t>(copy.size());
    copy.height = 1;
  }
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  pcl::PCDWriter writer;
  int rc = -1;
  try {
    rc = writer.writeBinary(tmp, copy);
  } catch (const std::exception& e) {
    std::remove(tmp.c_str());
    throw std::runtime_error("cannot write '" + path + "': " + e.what());
  }
  if (rc < 0) {
    std::remove(tmp.c_str());
    throw std::runtime_error("cannot write '" + path + "'");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw std::runtime_error("cannot write '" + path + "': rename failed");
  }
}

}  // namespace novelty_detection
