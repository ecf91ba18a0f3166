// Semi-real scenes (see the header).
#include "novelty_detection/sim/semireal.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <unordered_map>

#include "novelty_detection/sim/random.h"

namespace novelty_detection {
namespace sim {
namespace {

using Vec3 = Eigen::Vector3d;

std::vector<Vec3> finitePoints(const Cloud& cloud) {
  std::vector<Vec3> out;
  out.reserve(cloud.size());
  for (const PointT& p : cloud)
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))
      out.push_back(p.getVector3fMap().cast<double>());
  return out;
}

/// Integer cell key of a 3D grid.
struct Key {
  int x, y, z;
  bool operator==(const Key& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct KeyHash {
  std::size_t operator()(const Key& k) const {
    return (static_cast<std::size_t>(k.x) * 73856093u) ^
           (static_cast<std::size_t>(k.y) * 19349663u) ^
           (static_cast<std::size_t>(k.z) * 83492791u);
  }
};
Key keyOf(const Vec3& p, double cell) {
  return {static_cast<int>(std::floor(p.x() / cell)), static_cast<int>(std::floor(p.y() / cell)),
          static_cast<int>(std::floor(p.z() / cell))};
}

/// Voxel centroids of `points` on a `cell` grid, in first-seen order of the cells.
std::vector<Vec3> resample(const std::vector<Vec3>& points, double cell) {
  std::unordered_map<Key, std::size_t, KeyHash> slot;
  std::vector<Vec3> sum;
  std::vector<int> n;
  for (const Vec3& p : points) {
    auto [it, added] = slot.emplace(keyOf(p, cell), sum.size());
    if (added) sum.emplace_back(Vec3::Zero()), n.push_back(0);
    sum[it->second] += p;
    ++n[it->second];
  }
  for (std::size_t i = 0; i < sum.size(); ++i) sum[i] /= n[i];
  return sum;
}

/// Plane n . x + d = 0 with n toward the origin (the camera).
struct PlaneFit {
  Vec3 n = Vec3::UnitZ();
  double d = 0.0;
  std::size_t inliers = 0;
};

PlaneFit floorOfCameraFrame(const std::vector<Vec3>& pts) {
  const Vec3 down_axis(0.0, -1.0, 0.0);  // up in the optical frame
  const double tol = 0.03, min_cos = std::cos(30.0 * M_PI / 180.0);
  Rng rng(7);
  PlaneFit best;
  const std::size_t stride = std::max<std::size_t>(1, pts.size() / 20000);
  for (int it = 0; it < 400; ++it) {
    const Vec3& a = pts[rng() % pts.size()];
    const Vec3& b = pts[rng() % pts.size()];
    const Vec3& c = pts[rng() % pts.size()];
    Vec3 n = (b - a).cross(c - a);
    if (n.norm() < 1e-9) continue;
    n.normalize();
    if (std::abs(n.dot(down_axis)) < min_cos) continue;
    double d = -n.dot(a);
    if (d < 0) n = -n, d = -d;
    std::size_t count = 0;
    for (std::size_t i = 0; i < pts.size(); i += stride) count += std::abs(n.dot(pts[i]) + d) < tol;
    if (count > best.inliers) best = {n, d, count};
  }
  if (best.inliers == 0) throw std::runtime_error("no floor plane in the camera frame");
  // Least squares on all inliers.
  Vec3 mean = Vec3::Zero();
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  std::size_t count = 0;
  for (const Vec3& p : pts)
    if (std::abs(best.n.dot(p) + best.d) < tol) mean += p, ++count;
  mean /= count;
  for (const Vec3& p : pts)
    if (std::abs(best.n.dot(p) + best.d) < tol) cov += (p - mean) * (p - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  Vec3 n = es.eigenvectors().col(0);
  double d = -n.dot(mean);
  if (d < 0) n = -n, d = -d;
  return {n, d, count};
}

ObjectModel finish(std::vector<Vec3> pts, double spacing, const std::string& name) {
  ObjectModel m;
  m.name = name;
  m.spacing = spacing;
  Vec3 c = Vec3::Zero();
  for (const Vec3& p : pts) c += p;
  c /= std::max<std::size_t>(1, pts.size());
  for (Vec3& p : pts) p.x() -= c.x(), p.y() -= c.y();
  m.points.reserve(pts.size());
  for (const Vec3& p : pts) {
    m.height = std::max(m.height, p.z());
    m.radius = std::max(m.radius, std::hypot(p.x(), p.y()));
    PointT q;
    q.x = static_cast<float>(p.x()), q.y = static_cast<float>(p.y()),
    q.z = static_cast<float>(p.z());
    m.points.push_back(q);
  }
  return m;
}

/// A 2D grid (x, y) over a cloud's finite points, for column queries.
class ColumnGrid {
 public:
  ColumnGrid(const Cloud& cloud, double cell) : cell_(cell) {
    for (const PointT& p : cloud) {
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
      if (std::abs(p.x) > 1e6f || std::abs(p.y) > 1e6f) continue;
      cells_[{ix(p.x), ix(p.y), 0}].push_back(p.getVector3fMap().cast<double>());
    }
  }
  /// Calls f(point) for every point within `radius` (horizontally) of `c`.
  template <typename F>
  void forEach(const Vec3& c, double radius, F f) const {
    const int r = static_cast<int>(std::ceil(radius / cell_));
    const int cx = ix(c.x()), cy = ix(c.y());
    for (int x = cx - r; x <= cx + r; ++x)
      for (int y = cy - r; y <= cy + r; ++y) {
        auto it = cells_.find({x, y, 0});
        if (it == cells_.end()) continue;
        for (const Vec3& p : it->second)
          if (std::hypot(p.x() - c.x(), p.y() - c.y()) < radius) f(p);
      }
  }

 private:
  int ix(double v) const { return static_cast<int>(std::floor(v / cell_)); }
  double cell_;
  std::unordered_map<Key, std::vector<Vec3>, KeyHash> cells_;
};

/// Floor seen under the footprint, nothing below it, an empty column above it.
bool freeFloor(const ColumnGrid& grid, const Vec3& base, double radius, double height,
               std::size_t min_floor) {
  std::size_t floor = 0;
  bool blocked = false;
  grid.forEach(base, radius, [&](const Vec3& p) {
    const double h = p.z() - base.z();
    if (std::abs(h) < 0.05)
      ++floor;
    else if (h < -0.1 || (h > 0.08 && h < height + 0.3))
      blocked = true;
  });
  return !blocked && floor >= min_floor;
}

}  // namespace

ObjectModel cutNearestPerson(const Cloud& camera_cloud, double spacing) {
  const std::vector<Vec3> pts = finitePoints(camera_cloud);
  if (pts.size() < 1000) throw std::runtime_error("too few points to cut a person from");
  const PlaneFit floor = floorOfCameraFrame(pts);
  // Model axes: up = floor normal, x = the camera's view direction along the floor.
  const Vec3 up = floor.n;
  const Vec3 x = (Vec3::UnitZ() - Vec3::UnitZ().dot(up) * up).normalized();
  const Vec3 y = up.cross(x);
  std::vector<Vec3> above;
  for (const Vec3& p : pts) {
    const Vec3 q(p.dot(x), p.dot(y), up.dot(p) + floor.d);
    if (q.z() > 0.05 && q.z() < 2.3) above.push_back(q);
  }
  // Connected groups of 5 cm cells (26-neighbourhood).
  const double cell = 0.05;
  std::unordered_map<Key, std::vector<std::size_t>, KeyHash> cells;
  for (std::size_t i = 0; i < above.size(); ++i) cells[keyOf(above[i], cell)].push_back(i);
  std::unordered_map<Key, int, KeyHash> component;
  std::vector<std::vector<std::size_t>> groups;
  for (const auto& [start, unused] : cells) {
    if (component.count(start)) continue;
    const int id = static_cast<int>(groups.size());
    groups.emplace_back();
    std::vector<Key> stack{start};
    component[start] = id;
    while (!stack.empty()) {
      const Key k = stack.back();
      stack.pop_back();
      for (std::size_t i : cells.at(k)) groups[id].push_back(i);
      for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dz = -1; dz <= 1; ++dz) {
            const Key n{k.x + dx, k.y + dy, k.z + dz};
            if (cells.count(n) && !component.count(n)) component[n] = id, stack.push_back(n);
          }
    }
  }
  int best = -1;
  double best_range = std::numeric_limits<double>::infinity();
  for (std::size_t g = 0; g < groups.size(); ++g) {
    if (groups[g].size() < 500) continue;
    Eigen::AlignedBox3d box;
    double range = 0.0;
    for (std::size_t i : groups[g]) box.extend(above[i]), range += above[i].x();
    range /= groups[g].size();
    const Vec3 size = box.sizes();
    if (box.min().z() > 0.3 || box.max().z() < 1.3 || box.max().z() > 2.1) continue;
    if (size.x() > 1.0 || size.y() > 1.0) continue;
    if (range < best_range) best_range = range, best = static_cast<int>(g);
  }
  if (best < 0) throw std::runtime_error("no person standing on the floor found");
  std::vector<Vec3> person;
  for (std::size_t i : groups[best]) person.push_back(above[i]);
  return finish(resample(person, spacing), spacing, "person");
}

ObjectModel boxModel(const Eigen::Vector3d& size, double spacing) {
  if (!(size.minCoeff() > 0.0) || !(spacing > 0.0))
    throw std::invalid_argument("box size and spacing must be positive");
  const Vec3 h = size / 2.0;
  std::vector<Vec3> pts;
  auto steps = [&](double extent) {
    return std::max(1, static_cast<int>(std::ceil(extent / spacing)));
  };
  const int nx = steps(size.x()), ny = steps(size.y()), nz = steps(size.z());
  for (int i = 0; i <= nx; ++i)
    for (int j = 0; j <= ny; ++j)  // top
      pts.emplace_back(-h.x() + size.x() * i / nx, -h.y() + size.y() * j / ny, size.z());
  for (int k = 0; k < nz; ++k) {
    const double z = size.z() * k / nz;
    for (int i = 0; i <= nx; ++i) {
      const double xv = -h.x() + size.x() * i / nx;
      pts.emplace_back(xv, -h.y(), z), pts.emplace_back(xv, h.y(), z);
    }
    for (int j = 1; j < ny; ++j) {
      const double yv = -h.y() + size.y() * j / ny;
      pts.emplace_back(-h.x(), yv, z), pts.emplace_back(h.x(), yv, z);
    }
  }
  return finish(pts, spacing, "box");
}

Cloud placeModel(const ObjectModel& model, const Placement& where) {
  const Eigen::Matrix3f R =
      Eigen::AngleAxisf(static_cast<float>(where.yaw), Eigen::Vector3f::UnitZ()).toRotationMatrix();
  const Eigen::Vector3f t = where.base.cast<float>();
  Cloud out;
  out.reserve(model.points.size());
  for (const PointT& p : model.points) {
    PointT q;
    q.getVector3fMap() = R * p.getVector3fMap() + t;
    out.push_back(q);
  }
  return out;
}

namespace {

/// The beams of `scan` the placed model cuts: calls cut(i, point on the model) for each.
template <typename Cut>
void castInto(const Cloud& scan, const Eigen::Vector3f& sensor, const ObjectModel& model,
              const Placement& where, double hit_radius, Cut cut) {
  if (hit_radius <= 0.0) hit_radius = 1.5 * model.spacing;
  const Cloud placed = placeModel(model, where);
  if (placed.empty()) return;
  const Vec3 s = sensor.cast<double>();
  // Gnomonic projection about the direction to the object's centre.
  Vec3 centre = Vec3::Zero();
  for (const PointT& p : placed) centre += p.getVector3fMap().cast<double>();
  centre /= placed.size();
  const Vec3 e0 = (centre - s).normalized();
  const Vec3 e1 = e0.unitOrthogonal(), e2 = e0.cross(e1);
  std::vector<Vec3> obj;
  double r_min = std::numeric_limits<double>::infinity();
  for (const PointT& p : placed) {
    const Vec3 v = p.getVector3fMap().cast<double>() - s;
    if (v.dot(e0) < 0.1) continue;
    obj.push_back(v);
    r_min = std::min(r_min, v.norm());
  }
  if (obj.empty()) return;
  const double cell = 2.0 * hit_radius / r_min;
  std::unordered_map<Key, std::vector<std::size_t>, KeyHash> buckets;
  // A beam almost at right angles to e0 projects far out; clamped before the cast (such a
  // cell holds no object point, whose projections are bounded).
  auto index = [&](double u) {
    return static_cast<int>(std::clamp(std::floor(u / cell), -1e9, 1e9));
  };
  auto cellOf = [&](const Vec3& v) {
    const double t0 = v.dot(e0);
    return Key{index(v.dot(e1) / t0), index(v.dot(e2) / t0), 0};
  };
  for (std::size_t i = 0; i < obj.size(); ++i) buckets[cellOf(obj[i])].push_back(i);
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const PointT& p = scan[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
    const Vec3 v = p.getVector3fMap().cast<double>() - s;
    const double range = v.norm();
    if (v.dot(e0) <= 0.0 || range <= 0.0) continue;
    const Vec3 d = v / range;
    const Key k = cellOf(v);
    double t_hit = range - 2.0 * hit_radius;
    bool hit = false;
    for (int a = -1; a <= 1; ++a)
      for (int b = -1; b <= 1; ++b) {
        auto it = buckets.find({k.x + a, k.y + b, 0});
        if (it == buckets.end()) continue;
        for (std::size_t j : it->second) {
          const double t = obj[j].dot(d);
          if (t <= 0.0 || t >= t_hit) continue;
          if ((obj[j] - t * d).norm() < hit_radius) t_hit = t, hit = true;
        }
      }
    if (hit) cut(i, s + t_hit * d);
  }
}

/// How many beams of `scan` the placed model cuts (no copy of the sweep).
std::size_t beamsCut(const Cloud& scan, const Eigen::Vector3f& sensor, const ObjectModel& model,
                     const Placement& where) {
  std::size_t n = 0;
  castInto(scan, sensor, model, where, 0.0, [&](std::size_t, const Vec3&) { ++n; });
  return n;
}

}  // namespace

Insertion insertByRayCasting(const Cloud& scan, const Eigen::Vector3f& sensor,
                             const ObjectModel& model, const Placement& where, double hit_radius) {
  Insertion out;
  out.cloud = scan;
  out.truth.assign(scan.size(), 0);
  castInto(scan, sensor, model, where, hit_radius, [&](std::size_t i, const Vec3& q) {
    out.cloud[i].x = static_cast<float>(q.x());
    out.cloud[i].y = static_cast<float>(q.y());
    out.cloud[i].z = static_cast<float>(q.z());
    out.truth[i] = 1;
    ++out.replaced;
  });
  return out;
}

std::vector<Placement> freeFloorPlacements(const Cloud& current, const Eigen::Vector3f& sensor,
                                           const Cloud& reference, const ObjectModel& model,
                                           int count, std::uint64_t seed, std::size_t min_points) {
  const Vec3 s = sensor.cast<double>();
  auto horizontal = [&](const Vec3& p) { return std::hypot(p.x() - s.x(), p.y() - s.y()); };
  // Floor height: the most populated 2 cm band at least 0.1 m below the sensor, 1-6 m out.
  std::map<int, std::size_t> bands;
  const std::vector<Vec3> pts = finitePoints(current);
  for (const Vec3& p : pts) {
    const double h = horizontal(p);
    if (p.z() < s.z() - 0.1 && h > 1.0 && h < 6.0)
      ++bands[static_cast<int>(std::floor(p.z() / 0.02))];
  }
  if (bands.empty()) return {};
  const auto peak = std::max_element(
      bands.begin(), bands.end(), [](const auto& a, const auto& b) { return a.second < b.second; });
  const double floor_z = (peak->first + 0.5) * 0.02;
  // Candidates: a 0.2 m grid on the floor height around the sensor; the checks below keep
  // those in free space that both sweeps' beams crossed (not inside or behind structure).
  std::vector<Vec3> candidates;
  for (double x = -6.0; x <= 6.0; x += 0.2)
    for (double y = -6.0; y <= 6.0; y += 0.2) {
      const double h = std::hypot(x, y);
      if (h > 1.0 && h < 6.0) candidates.emplace_back(s.x() + x, s.y() + y, floor_z);
    }
  Rng rng(mixSeed(seed, 0x5e11));
  for (std::size_t i = candidates.size(); i > 1; --i)
    std::swap(candidates[i - 1], candidates[rng() % i]);
  const double radius = model.radius + 0.1;
  const ColumnGrid cur_grid(current, 0.25), ref_grid(reference, 0.25);
  std::vector<Placement> out;
  const std::size_t tries = std::min<std::size_t>(candidates.size(), 4000);
  for (std::size_t c = 0; c < tries && static_cast<int>(out.size()) < count; ++c) {
    Vec3 base = candidates[c];
    bool near_other = false;
    for (const Placement& o : out)
      near_other |= std::hypot(o.base.x() - base.x(), o.base.y() - base.y()) <
                    std::max(0.75, 2.0 * model.radius);
    if (near_other) continue;
    if (!freeFloor(cur_grid, base, radius, model.height, 0) ||
        !freeFloor(ref_grid, base, radius, model.height, 0))
      continue;
    // The base on the local floor: the median height of the current floor points under it.
    std::vector<double> zs;
    cur_grid.forEach(base, radius, [&](const Vec3& p) {
      if (std::abs(p.z() - base.z()) < 0.05) zs.push_back(p.z());
    });
    if (!zs.empty()) {
      std::nth_element(zs.begin(), zs.begin() + zs.size() / 2, zs.end());
      base.z() = zs[zs.size() / 2];
    }
    // The model's seen side (-x) toward the sensor, give or take 25 degrees.
    const double toward = std::atan2(base.y() - s.y(), base.x() - s.x());
    const Placement p{base, toward + uniform(rng, -25.0, 25.0) * M_PI / 180.0};
    if (beamsCut(current, sensor, model, p) < min_points) continue;
    // The reference's beams crossed the object's space: it was seen free there.
    if (beamsCut(reference, reference.sensor_origin_.head<3>(), model, p) < min_points) continue;
    out.push_back(p);
  }
  return out;
}

}  // namespace sim
}  // namespace novelty_detection
