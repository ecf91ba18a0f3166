#include "novelty_detection/preprocess/ignore_regions.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace novelty_detection {

namespace {

constexpr double kPi = 3.14159265358979323846;

[[noreturn]] void refuse(const std::string& box, const std::string& why) {
  throw std::invalid_argument("parameter preprocess/ignore_regions: box '" + box + "' " + why +
                              " (each box: 'xmin ymin zmin xmax ymax zmax [yaw_deg]' [m], "
                              "boxes separated by ';')");
}

std::string trimmed(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\n\r");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t\n\r");
  return s.substr(b, e - b + 1);
}

}  // namespace

bool IgnoreRegion::contains(const Eigen::Vector3d& p) const {
  const Eigen::Vector3d d = p - centre;
  const double c = std::cos(yaw_rad), s = std::sin(yaw_rad);
  // Into the box's axes: rotate by -yaw about z.
  const Eigen::Vector3d local(c * d.x() + s * d.y(), -s * d.x() + c * d.y(), d.z());
  return (local.array().abs() <= half_extent.array()).all();
}

std::vector<IgnoreRegion> parseIgnoreRegions(const std::string& text) {
  std::vector<IgnoreRegion> regions;
  std::istringstream boxes(text);
  std::string box;
  while (std::getline(boxes, box, ';')) {
    box = trimmed(box);
    if (box.empty()) continue;
    std::istringstream in(box);
    std::vector<double> v;
    std::string word;
    while (in >> word) {
      std::size_t used = 0;
      double x = 0.0;
      try {
        x = std::stod(word, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != word.size()) refuse(box, "has '" + word + "', not a number");
      v.push_back(x);
    }
    if (v.size() != 6 && v.size() != 7)
      refuse(box, "has " + std::to_string(v.size()) + " numbers, not 6 or 7");
    for (double x : v)
      if (!std::isfinite(x) || std::abs(x) > 1e6) refuse(box, "has a value beyond +-1e6");
    const Eigen::Vector3d lo(v[0], v[1], v[2]), hi(v[3], v[4], v[5]);
    if ((lo.array() > hi.array()).any()) refuse(box, "has a min above its max");
    IgnoreRegion r;
    r.centre = 0.5 * (lo + hi);
    r.half_extent = 0.5 * (hi - lo);
    r.yaw_rad = v.size() == 7 ? v[6] * kPi / 180.0 : 0.0;
    regions.push_back(r);
  }
  return regions;
}

std::string formatIgnoreRegions(const std::vector<IgnoreRegion>& regions) {
  std::ostringstream out;
  out << std::setprecision(std::numeric_limits<double>::max_digits10);
  for (std::size_t i = 0; i < regions.size(); ++i) {
    const IgnoreRegion& r = regions[i];
    const Eigen::Vector3d lo = r.centre - r.half_extent, hi = r.centre + r.half_extent;
    if (i > 0) out << "; ";
    out << lo.x() << ' ' << lo.y() << ' ' << lo.z() << ' ' << hi.x() << ' ' << hi.y() << ' '
        << hi.z();
    if (r.yaw_rad != 0.0) out << ' ' << r.yaw_rad * 180.0 / kPi;
  }
  return out.str();
}

bool inIgnoreRegion(const std::vector<IgnoreRegion>& regions, const Eigen::Vector3d& p) {
  for (const IgnoreRegion& r : regions)
    if (r.contains(p)) return true;
  return false;
}

std::size_t maskIgnoreRegions(const std::vector<IgnoreRegion>& regions, Cloud& cloud) {
  if (regions.empty()) return 0;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::size_t n = 0;
  for (PointT& p : cloud) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
    if (!inIgnoreRegion(regions, Eigen::Vector3d(p.x, p.y, p.z))) continue;
    p.x = p.y = p.z = nan;
    ++n;
  }
  if (n > 0) cloud.is_dense = false;
  return n;
}

std::size_t dropDisappearancesIn(const std::vector<IgnoreRegion>& regions, Result* r) {
  if (regions.empty()) return 0;
  std::vector<Segment> kept;
  std::vector<int> dropped;
  for (Segment& seg : r->disappeared_segments) {
    if (inIgnoreRegion(regions, seg.centroid))
      dropped.push_back(seg.id);
    else
      kept.push_back(std::move(seg));
  }
  if (dropped.empty()) return 0;
  auto isDropped = [&dropped](int id) {
    return std::find(dropped.begin(), dropped.end(), id) != dropped.end();
  };
  r->disappeared_segments.swap(kept);
  for (int& l : r->disappeared_labels)
    if (l > 0 && isDropped(l)) l = 0;
  auto& sqs = r->disappeared_superquadrics;
  sqs.erase(std::remove_if(sqs.begin(), sqs.end(),
                           [&](const Superquadric& sq) { return isDropped(sq.segment); }),
            sqs.end());
  return dropped.size();
}

}  // namespace novelty_detection
