#include "novelty_detection/io/cloud_io.h"

#include "io/pcd_reader.h"

#include <pcl/PCLPointCloud2.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <locale>
#include <new>
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

/// The field `name` of a PLY blob when it is a float or a double (one value); refuses a
/// missing, non-floating or repeated one.
const pcl::PCLPointField& coordinateField(const std::string& path, const pcl::PCLPointCloud2& blob,
                                          const char* name) {
  const pcl::PCLPointField* found = nullptr;
  for (const auto& f : blob.fields) {
    if (f.name != name) continue;
    if (found) fail(path, std::string("field '") + name + "' given twice");
    found = &f;
  }
  if (!found || found->count < 1 ||
      (found->datatype != pcl::PCLPointField::FLOAT32 &&
       found->datatype != pcl::PCLPointField::FLOAT64))
    fail(path, "it has no float or double x, y, z fields");
  const std::size_t size = found->datatype == pcl::PCLPointField::FLOAT32 ? 4 : 8;
  if (static_cast<std::size_t>(found->offset) + size > blob.point_step)
    fail(path, std::string("field '") + name + "' lies outside the point");
  return *found;
}

/// x, y, z of every point of a PLY blob (float or double fields), as the cloud's floats.
Cloud xyzFromBlob(const std::string& path, const pcl::PCLPointCloud2& blob) {
  const pcl::PCLPointField* f[3] = {&coordinateField(path, blob, "x"),
                                    &coordinateField(path, blob, "y"),
                                    &coordinateField(path, blob, "z")};
  Cloud cloud;
  const std::size_t n = static_cast<std::size_t>(blob.width) * blob.height;
  cloud.resize(n);
  cloud.width = blob.width;
  cloud.height = blob.height;
  cloud.is_dense = false;
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint8_t* point = blob.data.data() + i * blob.point_step;
    float* out = cloud[i].data;
    for (int k = 0; k < 3; ++k) {
      const std::uint8_t* at = point + f[k]->offset;
      if (f[k]->datatype == pcl::PCLPointField::FLOAT32) {
        std::memcpy(&out[k], at, sizeof(float));
      } else {
        double v;
        std::memcpy(&v, at, sizeof(double));
        out[k] = static_cast<float>(v);  // beyond float range: +-inf, refused downstream
      }
    }
  }
  return cloud;
}

// The PLY counterpart: PCL allocates element storage from the header's counts before
// reading, so counts must be sane numbers that the file can actually hold.
void validatePlyHeader(const std::string& path, std::uintmax_t file_size,
                       const LoadLimits& limits) {
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
  std::set<std::string> properties;  // of the current element
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
      if (name == "vertex") {
        vertex = true;
        if (static_cast<std::uint64_t>(n) > limits.max_points) {
          fail(path, std::to_string(n) + " points, more than " + limits.parameter + " = " +
                         std::to_string(limits.max_points));
        }
      }
      current_count = static_cast<std::uintmax_t>(n);
      current_is_list = false;
      properties.clear();
    } else if (key == "property") {
      std::string type, name;
      ls >> type;
      if (type == "list") {
        current_is_list = true;
        std::string count_type, item_type;
        ls >> count_type >> item_type;
      }
      ls >> name;
      if (!properties.insert(name).second)
        fail(path, "field '" + name.substr(0, 32) + "' given twice");
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

CloudFile loadCloudFile(const std::string& path, const LoadLimits& limits) {
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
      // Our own reader: PCL's trusts the header's description of the body (see pcd_reader.h).
      CloudFile out = detail::readPcdFile(path, static_cast<std::uintmax_t>(st.st_size), limits);
      out.cloud.sensor_origin_.head<3>() = out.T_frame_sensor.translation().cast<float>();
      out.cloud.sensor_origin_[3] = 0.f;
      out.cloud.sensor_orientation_ = Eigen::Quaternionf(out.T_frame_sensor.linear().cast<float>());
      return out;
    } else if (ext == "ply") {
      validatePlyHeader(path, static_cast<std::uintmax_t>(st.st_size), limits);
      pcl::PLYReader reader;
      int version = 0;
      rc = reader.read(path, blob, origin, orientation, version);
    } else {
      fail(path, "unknown extension '." + ext + "' (expected .pcd or .ply)");
    }
  } catch (const std::runtime_error&) {
    throw;
  } catch (const std::bad_alloc&) {
    fail(path, "out of memory while loading it: the cloud it declares does not fit in this "
               "machine's memory (lower " + limits.parameter + " to refuse such files from "
               "their header)");
  } catch (const std::exception& e) {
    fail(path, e.what());
  }
  if (rc < 0) fail(path, "malformed or truncated " + ext + " file");
  const std::size_t expected = static_cast<std::size_t>(blob.width) * blob.height * blob.point_step;
  if (blob.data.size() < expected) fail(path, "data shorter than its header declares");

  CloudFile out;
  out.cloud = xyzFromBlob(path, blob);  // float or double x, y, z (Open3D writes doubles)
  const Eigen::Quaterniond q = orientation.cast<double>();
  out.T_frame_sensor.linear() =
      q.norm() > 0.5 ? q.normalized().toRotationMatrix() : Eigen::Matrix3d::Identity();
  out.T_frame_sensor.translation() = origin.head<3>().cast<double>();
  // Keep the viewpoint on the cloud too, as PCL does, for code that reads it from there.
  out.cloud.sensor_origin_ = Eigen::Vector4f(origin[0], origin[1], origin[2], 0.f);
  out.cloud.sensor_orientation_ = Eigen::Quaternionf(out.T_frame_sensor.linear().cast<float>());
  return out;
}

Cloud loadCloud(const std::string& path, const LoadLimits& limits) {
  return loadCloudFile(path, limits).cloud;
}

namespace {

/// write(2) of all `size` bytes; false on an error (errno set).
bool writeAll(int fd, const char* data, std::size_t size) {
  while (size > 0) {
    const ssize_t n = ::write(fd, data, size);
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    data += n;
    size -= static_cast<std::size_t>(n);
  }
  return true;
}

}  // namespace

void saveCloudAtomic(const std::string& path, const Cloud& cloud,
                     const Eigen::Isometry3d& T_frame_sensor) {
  const std::size_t slash = path.find_last_of('/');
  const std::string dir =
      slash == std::string::npos ? "." : (slash == 0 ? "/" : path.substr(0, slash));
  const std::string base = slash == std::string::npos ? path : path.substr(slash + 1);
  if (base.empty() || base == "." || base == "..")
    throw std::runtime_error("cannot write '" + path + "': no file name");
  // A fresh temporary file beside the target (mkstemp: O_EXCL, a random name, so a file or
  // symlink planted there is never opened), written, flushed to disk, then renamed over the
  // target and the directory flushed: a reader sees the old file or the whole new one.
  std::string name = dir + "/." + base + ".XXXXXX";
  const int fd = ::mkstemp(name.data());
  if (fd < 0) {
    throw std::runtime_error("cannot write '" + path + "': cannot create a file in '" + dir +
                             "': " + std::strerror(errno));
  }
  auto failWith = [&](const std::string& what) {
    const int err = errno;
    ::close(fd);
    ::unlink(name.c_str());
    throw std::runtime_error("cannot write '" + path + "': " + what + ": " + std::strerror(err));
  };
  const bool organised = cloud.width * cloud.height == cloud.size();
  const Eigen::Vector3d t = T_frame_sensor.translation();
  const Eigen::Quaterniond q = Eigen::Quaterniond(T_frame_sensor.linear()).normalized();
  std::ostringstream header;
  header.imbue(std::locale::classic());
  header.precision(17);
  header << "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z\n"
         << "SIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH "
         << (organised ? cloud.width : cloud.size()) << "\nHEIGHT "
         << (organised ? cloud.height : 1u) << "\nVIEWPOINT " << t.x() << ' ' << t.y() << ' '
         << t.z() << ' ' << q.w() << ' ' << q.x() << ' ' << q.y() << ' ' << q.z() << "\nPOINTS "
         << cloud.size() << "\nDATA binary\n";
  const std::string h = header.str();
  std::vector<float> xyz;
  xyz.reserve(3 * cloud.size());
  for (const auto& p : cloud) xyz.insert(xyz.end(), {p.x, p.y, p.z});
  if (!writeAll(fd, h.data(), h.size()) ||
      !writeAll(fd, reinterpret_cast<const char*>(xyz.data()), xyz.size() * sizeof(float)))
    failWith("write failed");
  if (::fsync(fd) != 0) failWith("fsync failed");
  const mode_t mask = ::umask(0);
  ::umask(mask);
  if (::fchmod(fd, 0666 & ~mask) != 0) failWith("chmod failed");
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(name.c_str());
    throw std::runtime_error("cannot write '" + path + "': close failed: " + std::strerror(err));
  }
  if (std::rename(name.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(name.c_str());
    throw std::runtime_error("cannot write '" + path + "': rename failed: " + std::strerror(err));
  }
  const int dir_fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
  if (dir_fd >= 0) {
    ::fsync(dir_fd);  // the rename itself on disk; best effort (some filesystems refuse)
    ::close(dir_fd);
  }
}

}  // namespace novelty_detection
