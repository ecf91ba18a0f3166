#include "novelty_detection/visibility/visibility.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/parallel.h"

namespace novelty_detection {
namespace {

constexpr double kTwoPi = 2.0 * M_PI;

struct Ray {
  float az, el, range;
};

// The 90th percentile of the lengths of empty runs bounded by returns on both sides, along
// rows or along columns; 0 when there is none. Most such runs are the gaps between scan
// lines; the high quantile takes the sparsest part of the pattern (the gaps of a tilting
// laser shrink towards its tilt axis).
int internalGapQuantile(const std::vector<char>& occupied, int cols, int rows, bool along_rows) {
  std::vector<int> runs;
  const int outer = along_rows ? rows : cols, inner = along_rows ? cols : rows;
  for (int a = 0; a < outer; ++a) {
    int last = -1;
    for (int b = 0; b < inner; ++b) {
      const int idx = along_rows ? a * cols + b : b * cols + a;
      if (!occupied[idx]) continue;
      if (last >= 0 && b - last > 1) runs.push_back(b - last - 1);
      last = b;
    }
  }
  if (runs.empty()) return 0;
  const auto q = runs.begin() + static_cast<std::ptrdiff_t>(0.9 * (runs.size() - 1));
  std::nth_element(runs.begin(), q, runs.end());
  return *q;
}

}  // namespace

bool RangeImage::cellOf(const Eigen::Vector3f& d, int* col, int* row, float* range) const {
  const float r = d.norm();
  if (!(r > 1e-6f) || !std::isfinite(r)) return false;
  const double az = std::atan2(d.y(), d.x());
  const double el = std::asin(std::clamp(d.z() / r, -1.0f, 1.0f));
  const int rr = static_cast<int>(std::floor((el - el_min_) / cell_rad_));
  if (rr < 0 || rr >= rows_) return false;
  int cc = static_cast<int>(std::floor((az + M_PI) / cell_rad_));
  cc = ((cc % cols_) + cols_) % cols_;
  *col = cc;
  *row = rr;
  *range = r;
  return true;
}

void RangeImage::build(const Cloud& cloud, const Indices& indices, const Eigen::Vector3f& origin,
                       const Config& config) {
  *this = RangeImage();
  origin_ = origin;
  slack_factor_ = config.slack_factor;
  std::vector<Ray> rays;
  rays.reserve(indices.empty() ? cloud.size() : indices.size());
  auto add = [&](const PointT& p) {
    const Eigen::Vector3f d = p.getVector3fMap() - origin;
    const float r = d.norm();
    if (!std::isfinite(r) || !(r > 1e-6f)) return;
    rays.push_back({static_cast<float>(std::atan2(d.y(), d.x())),
                    static_cast<float>(std::asin(std::clamp(d.z() / r, -1.0f, 1.0f))), r});
  };
  if (indices.empty()) {
    for (const auto& p : cloud) add(p);
  } else {
    for (int i : indices) add(cloud[i]);
  }
  const std::size_t n = rays.size();
  if (n < 3) return;
  float el_lo = std::numeric_limits<float>::infinity(), el_hi = -el_lo;
  for (const Ray& r : rays) el_lo = std::min(el_lo, r.el), el_hi = std::max(el_hi, r.el);

  // Mean angular spacing of the returns, sqrt(solid angle they cover / count). The covered
  // solid angle is counted on a coarse grid whose cells hold ~16 returns if the whole band
  // of elevations were covered evenly, so gaps between scan lines do not count as uncovered.
  const double band = std::max(kTwoPi * (std::sin(el_hi) - std::sin(el_lo)), 1e-9);
  const double c0 = std::min(4.0 * std::sqrt(band / static_cast<double>(n)), M_PI / 4);
  const int cols0 = static_cast<int>(std::ceil(kTwoPi / c0));
  const int rows0 = static_cast<int>(std::floor((el_hi - el_lo) / c0)) + 1;
  std::vector<char> coarse(static_cast<std::size_t>(cols0) * rows0, 0);
  for (const Ray& r : rays) {
    const int cc = std::min(cols0 - 1, static_cast<int>((r.az + M_PI) / c0));
    const int rr = std::min(rows0 - 1, static_cast<int>((r.el - el_lo) / c0));
    coarse[static_cast<std::size_t>(rr) * cols0 + cc] = 1;
  }
  double covered = 0.0;
  for (int rr = 0; rr < rows0; ++rr) {
    const double lo = el_lo + rr * c0, hi = std::min<double>(lo + c0, M_PI / 2);
    for (int cc = 0; cc < cols0; ++cc)
      if (coarse[static_cast<std::size_t>(rr) * cols0 + cc])
        covered += c0 * (std::sin(hi) - std::sin(lo));
  }
  double cell = config.cell_factor * std::sqrt(std::max(covered, 1e-12) / static_cast<double>(n));
  const double el_span = std::max<double>(el_hi - el_lo, 0.0);
  const double min_cell =
      std::sqrt(kTwoPi * std::max(el_span, 1e-6) /
                static_cast<double>(std::max<std::size_t>(config.max_cells, 1)));
  cell = std::clamp(cell, std::max(min_cell, 1e-5), M_PI / 8);
  // Whole columns round the circle: a last, narrower column would hold too few returns and
  // leave the directions about azimuth +-180 deg unknown (a sensor facing -x).
  cols_ = static_cast<int>(std::ceil(kTwoPi / cell));
  cell = kTwoPi / cols_;
  cell_rad_ = cell;
  el_min_ = el_lo;
  rows_ = static_cast<int>(std::floor(el_span / cell)) + 1;

  std::vector<Cell> raw(static_cast<std::size_t>(cols_) * rows_,
                        Cell{std::numeric_limits<float>::infinity(), 0.f});
  std::vector<char> occupied(raw.size(), 0);
  for (const Ray& r : rays) {
    int cc = static_cast<int>(std::floor((r.az + M_PI) / cell));
    cc = ((cc % cols_) + cols_) % cols_;
    const int rr = std::min(rows_ - 1, static_cast<int>((r.el - el_lo) / cell));
    const std::size_t idx = static_cast<std::size_t>(rr) * cols_ + cc;
    raw[idx].near = std::min(raw[idx].near, r.range);
    raw[idx].far = std::max(raw[idx].far, r.range);
    occupied[idx] = 1;
  }

  // Fill the gaps between scan lines: an empty run between two returns of the same column
  // (then of the same row) no longer than fill_factor times the axis' typical gap takes
  // the nearer and farther range of the two returns that bound it. Runs open on one side
  // (outside the field of view, beyond the last return) stay unknown.
  const int gv = internalGapQuantile(occupied, cols_, rows_, false);
  const int gh = internalGapQuantile(occupied, cols_, rows_, true);
  fill_rows_ = static_cast<int>(std::floor(config.fill_factor * gv));
  fill_cols_ = static_cast<int>(std::floor(config.fill_factor * gh));
  cells_ = raw;
  auto fill_runs = [this](std::vector<char>& known, bool along_rows, int max_run) {
    if (max_run <= 0) return;
    const int outer = along_rows ? rows_ : cols_, inner = along_rows ? cols_ : rows_;
    auto at = [&](int a, int b) {
      return static_cast<std::size_t>(along_rows ? a * cols_ + b : b * cols_ + a);
    };
    std::vector<char> filled(known.size(), 0);
    // Rows close round the circle of azimuths: a run may cross the +-180 deg seam.
    const int wrap = along_rows ? inner : 0;
    for (int a = 0; a < outer; ++a) {
      int first = -1, last = -1;
      auto fill = [&](int from, int to) {  // the empty cells strictly between, modulo inner
        if (to - from <= 1 || to - from - 1 > max_run) return;
        const Cell& lo = cells_[at(a, from % inner)];
        const Cell& hi = cells_[at(a, to % inner)];
        const Cell c{std::min(lo.near, hi.near), std::max(lo.far, hi.far)};
        for (int k = from + 1; k < to; ++k) {
          cells_[at(a, k % inner)] = c;
          filled[at(a, k % inner)] = 1;
        }
      };
      for (int b = 0; b < inner; ++b) {
        if (!known[at(a, b)]) continue;
        if (first < 0) first = b;
        if (last >= 0) fill(last, b);
        last = b;
      }
      if (wrap > 0 && first >= 0 && last > first) fill(last, first + wrap);
    }
    for (std::size_t i = 0; i < known.size(); ++i) known[i] = known[i] || filled[i];
  };
  // A scanning pattern leaves its gaps along one axis (a tilting laser: elevation; a laser
  // spun about the vertical: azimuth); runs along the other axis span between distant parts
  // of the pattern (e.g. across the wedge of a tilting laser's tilt axis) and are only
  // filled when they are as short as the gaps of the first axis (a pattern sparse on both).
  const bool rows_first = fill_cols_ > 0 && (fill_rows_ == 0 || fill_cols_ < fill_rows_);
  int& first = rows_first ? fill_cols_ : fill_rows_;
  int& second = rows_first ? fill_rows_ : fill_cols_;
  if (second > 2 * std::max(first, 1)) second = 0;
  // At least one cell along both axes: the cell is the mean spacing of the returns, so a
  // regular pattern binned into it leaves isolated empty rows and columns (aliasing).
  first = std::max(first, 1);
  second = std::max(second, 1);
  std::vector<char> known = occupied;
  fill_runs(known, rows_first, first);
  fill_runs(known, !rows_first, second);
}

Visibility RangeImage::classify(const Eigen::Vector3f& p, double margin_m,
                                Neighbourhood mode) const {
  if (empty()) return Visibility::kUnknown;
  int col = 0, row = 0;
  float r = 0.f;
  if (!cellOf(p - origin_, &col, &row, &r)) return Visibility::kUnknown;
  float near = std::numeric_limits<float>::infinity(), far = -near;
  for (int dr = -1; dr <= 1; ++dr) {
    const int rr = row + dr;
    if (rr < 0 || rr >= rows_) return Visibility::kUnknown;
    for (int dc = -1; dc <= 1; ++dc) {
      const Cell& c = cells_[static_cast<std::size_t>(rr) * cols_ + (col + dc + cols_) % cols_];
      // A cell without returns next to p: p is at the edge of the view or of a gap too
      // wide to fill, where the returns on one side alone would mislead (a grazing ceiling
      // seen through one scan line looks farther than it is).
      if (c.near > c.far) return Visibility::kUnknown;
      near = std::min(near, c.near);
      far = std::max(far, c.far);
    }
  }
  if (mode == Neighbourhood::kOwnCell) {
    // The own cell's range, widened by slack_factor times the 3x3 spread (large at grazing
    // incidence and at depth edges, ~0 on a surface facing the sensor).
    const Cell& own = cells_[static_cast<std::size_t>(row) * cols_ + col];
    const float slack = static_cast<float>(slack_factor_) * (far - near);
    near = own.near - slack;
    far = own.far + slack;
  }
  if (r < near - margin_m) return Visibility::kFree;
  if (r > far + margin_m) return Visibility::kOccluded;
  return Visibility::kOccupied;
}

std::vector<std::uint8_t> newlyVisible(
    const Cloud& current, const std::vector<int>& labels, const ReferenceVisibility& reference,
    double margin_m, const std::function<bool(const Eigen::Vector3f&)>& far_from_map, int threads) {
  std::vector<std::uint8_t> out(current.size(), 0);
  if (reference.empty()) return out;
  // Blocks of consecutive points, each writing only its own slots.
  constexpr int kBlock = 2048;
  detail::parallelForBlocks(static_cast<int>(current.size()), kBlock, threads, [&](int i) {
    if (labels[i] != 0) return;
    const Eigen::Vector3f p = current[i].getVector3fMap();
    if (!p.allFinite()) return;
    const Visibility v = reference.classify(p, margin_m, RangeImage::Neighbourhood::kOwnCell);
    if (v != Visibility::kOccluded && v != Visibility::kUnknown) return;
    if (far_from_map(p)) out[i] = 1;
  });
  return out;
}

}  // namespace novelty_detection
