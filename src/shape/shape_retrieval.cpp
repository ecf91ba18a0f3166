#include "novelty_detection/shape/shape_retrieval.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>

#include "common/parallel.h"
#include "novelty_detection/point_grid.h"
#include "novelty_detection/shape/split_merge.h"
#include "novelty_detection/shape/standing_parts.h"
#include "novelty_detection/shape/superquadric.h"
#include "novelty_detection/shape/superquadric_fit.h"

namespace novelty_detection {
namespace {
// An ellipsoid's exponents may move this little from 1 (bounds need some room).
constexpr double kRoundBand = 0.02;
// Fewest points of a part of a standing composite (a superquadric has 11 parameters).
constexpr int kMinStandingPartPoints = 12;
// A standing composite is deeper than a flat view: its points' spread across their best
// plane, less the noise, exceeds this share of their spread along it (people: 0.25 and more;
// door leaves, however noisy or partly seen, mostly below 0.2).
constexpr double kCompositeDepth = 0.2;

/// An upright fit (its z axis along up) whose horizontal section lies between an ellipse and a
/// diamond (e2 > 1) is also where a fit of a rectangular section ends that turned the wrong
/// way from its start: a diamond is a square turned by 45 deg, and LM does not cross the
/// rounder sections between (LM fits of superquadrics have local minima in the orientation;
/// Solina & Bajcsy, PAMI 1990). So the fit is refined again from the rectangle that
/// diamond would be (the model turned by 45 deg about up, e2 mirrored about 1, 2 - e2 but at
/// least epsilon_min, both horizontal semi-axes their mean over sqrt 2: a diamond's
/// half-diagonal is the square's half-side times sqrt 2), on the same points by the same
/// fitter, and the lower objective wins.
FitResult withTurnedSection(const SuperquadricFitter& fitter, const Points3d& points,
                            const FitResult& fit, const Eigen::Vector3d& up, double epsilon_min) {
  const Eigen::Matrix3d r = fit.sq.rotation();
  if (!(fit.sq.e2 > 1.0) || uprightAxis(r, up) != 2) return fit;
  Superquadric turned = fit.sq;
  turned.euler = eulerZyzFromRotation(Eigen::AngleAxisd(M_PI / 4.0, up) * r);
  turned.e2 = std::max(epsilon_min, 2.0 - fit.sq.e2);
  turned.a[0] = turned.a[1] = 0.5 * (fit.sq.a[0] + fit.sq.a[1]) / std::sqrt(2.0);
  const FitResult other = fitter.refine(points, turned, -1, true, FitMeasures::kNone);
  return other.cost < fit.cost ? other : fit;
}

/// The parts of a tall object standing on the floor, cut where its horizontal section steps
/// (standing_parts.h), each with a first fit; empty when it is not one (no floor, not
/// standing on it, no deeper than kCompositeDepth: one surface) or its section does not step.
std::vector<SuperquadricPart> standingComposite(const Points3d& points, const FitBounds* bounds,
                                                const SuperquadricFitter& fitter, int max_parts,
                                                int threads) {
  if (!bounds || !bounds->has_floor || !bounds->standsOnFloor(points) ||
      bounds->isFlat(points, kCompositeDepth)) {
    return {};
  }
  const std::vector<Indices> groups =
      standingParts(points, bounds->up, bounds->floor_offset, kMinStandingPartPoints);
  if (groups.size() < 2 || static_cast<int>(groups.size()) > max_parts) return {};
  std::vector<SuperquadricPart> parts(groups.size());
  detail::parallelFor(static_cast<int>(groups.size()), threads, [&](int k) {
    SuperquadricPart& part = parts[static_cast<std::size_t>(k)];
    part.indices = groups[static_cast<std::size_t>(k)];
    Points3d members;
    members.reserve(part.indices.size());
    for (int i : part.indices) members.push_back(points[static_cast<std::size_t>(i)]);
    part.fit = fitter.fit(subsample(members, fitter.params().max_fit_points), -1, true,
                          FitMeasures::kNone);
  });
  return parts;
}
}  // namespace

ShapeRetrieval::ShapeRetrieval(const SuperquadricParams& params) : params_(params) {
  params_.validate();
}

std::vector<Superquadric> ShapeRetrieval::recover(const Points3d& fine, const Points3d& coarse,
                                                  int segment_id, const FitBounds* bounds) const {
  if (!params_.enabled) return {};
  if (fine.empty()) {
    throw std::invalid_argument("ShapeRetrieval::recover: segment " + std::to_string(segment_id) +
                                " has no points");
  }
  const SuperquadricFitter fitter(params_);
  // The final fits within what the sweep observed around the segment.
  SuperquadricFitter bounded(params_);
  if (bounds && !bounds->empty()) bounded.setBounds(bounds);
  Indices sm_index;
  const Points3d sm_points = subsample(fine, params_.split_max_points, &sm_index);
  const Points3d sub = subsample(sm_points, params_.max_fit_points);
  // The final bounded fit also sees the hidden side by symmetry (fit_bounds.h): the points
  // with their reflection, thinned to the fit's point budget; just the points without one.
  // The model is moved first to the completed set's centre on the floor plan (the middle of
  // the silhouette), so that the refinement does not stay in the hidden space the unbounded
  // fit reached into.
  const auto with_hidden_side = [&](const Points3d& seen, double roundness, Superquadric* model,
                                    bool standing_part = false, bool round_section = false) {
    if (!bounds) return seen;
    const Points3d mirrored =
        mirroredHiddenSide(seen, *bounds, roundness, standing_part, round_section);
    if (mirrored.empty()) return seen;
    Points3d both = seen;
    both.insert(both.end(), mirrored.begin(), mirrored.end());
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (const auto& p : both) centre += p;
    centre /= static_cast<double>(both.size());
    const Eigen::Vector3d shift = centre - model->position;
    model->position += shift - shift.dot(bounds->up) * bounds->up;
    return subsample(both, params_.max_fit_points);
  };

  // A segment taken to stand on the floor through hidden space also gains its hidden lower
  // part (fit_bounds.h), thinned with its points to the fit's point budget.
  const auto with_lower_part = [&](Points3d points) {
    if (!bounds) return points;
    const Points3d below = extrudedToFloor(points, *bounds);
    if (below.empty()) return points;
    points.insert(points.end(), below.begin(), below.end());
    return subsample(points, params_.max_fit_points);
  };

  // A tall composite standing on the floor (a person) is cut where its section steps, into
  // legs, trunk, limbs and head (standing_parts.h), not by split and merge's cuts across
  // its main axis, which slice the body into slabs.
  std::vector<SuperquadricPart> parts;
  if (params_.standing_parts) {
    parts = standingComposite(sm_points, bounds, fitter, params_.max_parts, threads_);
  }
  const bool standing = !parts.empty();

  // Multi-scale fitting (Sec. V-B): a fit on the coarse representatives refined on the finer
  // points, and a fit on the finer points from the moment initialisation; the lower mean
  // radial distance on the finer points wins.
  // Round unless the data demand corners: the free exponents fit a one-sided view of a
  // round object about as well with a flattened, box-like shape whose unseen extent is wrong.
  // An ellipsoid (e1 = e2 = 1), fitted from the same starts, replaces the free fit unless the
  // free one's mean surface distance is lower by more than corner_gain of the ellipsoid's
  // (both mostly the sensor noise when they fit, so the bar scales with it).
  const bool round_check = params_.corner_gain > 0.0;
  auto round_wins = [&](double round_distance, double free_distance) {
    return round_distance * (1.0 - params_.corner_gain) <= free_distance;
  };
  SuperquadricParams round = params_;
  round.epsilon_min = 1.0 - kRoundBand;
  round.epsilon_max = 1.0 + kRoundBand;
  const SuperquadricFitter round_fitter(round);

  // The three fits are independent: in parallel (none for a standing composite).
  bool coarse_usable = coarse.size() >= 11;
  for (const auto& p : coarse) coarse_usable = coarse_usable && p.allFinite();
  FitResult fits[2], ellipsoid;
  detail::parallelFor(standing ? 0 : 3, threads_, [&](int k) {
    if (k == 2) {
      if (round_check) ellipsoid = round_fitter.fit(sub, -1, true, FitMeasures::kSurface);
      return;
    }
    if (k == 1 && !coarse_usable) return;
    // Only the mean radial distance (the choice) and the model are used here.
    fits[k] = k == 0 ? fitter.fit(sub, -1, true, FitMeasures::kRadial)
                     : fitter.refine(sub,
                                     fitter
                                         .fit(subsample(coarse, params_.max_fit_points), -1, true,
                                              FitMeasures::kNone)
                                         .sq,
                                     -1, true, FitMeasures::kRadial);
  });
  FitResult best = fits[0];
  if (coarse_usable && fits[1].mean_radial_distance < best.mean_radial_distance) best = fits[1];
  const bool round_section = !standing && round_check &&
                             round_wins(ellipsoid.mean_distance, meanSurfaceDistance(best.sq, sub));
  if (round_section) best = ellipsoid;

  // The whole segment as one part, fitted within what the sweep observed.
  const bool bounded_fit = bounds && !bounds->empty();
  const auto bounded_whole = [&](const FitResult& start) {
    // The ellipsoid kept: its section is round, and its centre is found from its
    // curvature (fit_bounds.h).
    Superquadric model = start.sq;
    const Points3d seen = with_lower_part(with_hidden_side(sub, 0.0, &model, false, round_section));
    FitResult fit = bounded.refine(seen, model, -1, true, FitMeasures::kNone);
    fit = withTurnedSection(bounded, seen, fit, bounds->up, params_.epsilon_min);
    // A round section's silhouette ends lie in front of its centre: mirror again knowing
    // how round the first fit came out.
    const double roundness = bounds->has_floor ? horizontalRoundness(fit.sq, bounds->up) : 0.0;
    model = fit.sq;
    const Points3d data =
        roundness > 0.0 ? with_lower_part(with_hidden_side(sub, roundness, &model)) : seen;
    if (roundness > 0.0) fit = bounded.refine(data, model, -1, true, FitMeasures::kNone);
    // Then once more with the middles of the gaps the sweep left around it, together
    // weighing a quarter of the points.
    const Points3d middles =
        bounds->standsOnFloor(sub) ? gapMiddles(fit.sq, *bounds, &sub) : Points3d();
    if (!middles.empty()) {
      Points3d with_gaps = data;
      const std::size_t copies = std::max<std::size_t>(1, data.size() / (4 * middles.size()));
      for (std::size_t c = 0; c < copies; ++c)
        with_gaps.insert(with_gaps.end(), middles.begin(), middles.end());
      fit = bounded.refine(with_gaps, fit.sq, -1, true, FitMeasures::kNone);
    }
    const std::optional<Eigen::Vector3d> origin = bounds->sensorOrigin();
    thinToFlatView(sub, bounds->noise_m, params_.min_size_m, &fit.sq, origin ? &*origin : nullptr);
    return fit;
  };

  // Split and merge (Sec. V-C) on a larger subsample, so that small parts keep enough points.
  SplitMerge split_merge(params_);
  split_merge.setThreads(threads_);
  // The nugget of dense, noisy views comes out low; the sweep's noise model bounds it.
  if (bounds) split_merge.setSensorNoise(bounds->noise_m);
  if (!standing) {
    // With bounds, the bounded whole fit is also the one part split and merge keeps when it
    // explains the points (SplitMerge::run()); without that test it is made only when split
    // and merge leaves one part.
    const bool one_part_test = bounded_fit && params_.one_part_tolerance >= 0.0;
    const FitResult whole = one_part_test ? bounded_whole(best) : FitResult();
    parts = split_merge.run(sm_points, &best, one_part_test ? &whole : nullptr);
    if (parts.size() == 1) {
      parts.front().fit = one_part_test ? whole : bounded_fit ? bounded_whole(best) : best;
    }
  }

  // Every fine point goes to its part: points left out by the subsampling take the part of
  // their nearest kept neighbour (or, if none is near, of the nearest surface).
  std::vector<int> sm_label(sm_points.size(), 0);
  for (std::size_t k = 0; k < parts.size(); ++k) {
    for (int i : parts[k].indices) sm_label[static_cast<std::size_t>(i)] = static_cast<int>(k);
  }
  std::vector<int> label(fine.size(), -1);
  for (std::size_t i = 0; i < sm_index.size(); ++i) {
    label[static_cast<std::size_t>(sm_index[i])] = sm_label[i];
  }
  std::unique_ptr<PointGrid> grid;
  const double spacing = medianSpacing(sm_points);
  if (parts.size() > 1 && fine.size() > sm_points.size() && spacing > 0.0) {
    grid = std::make_unique<PointGrid>(sm_points, params_.neighbour_distance_factor * spacing);
  }
  std::vector<Superquadric> out(parts.size());
  std::vector<Points3d> part_points(parts.size());
  for (std::size_t i = 0; i < fine.size(); ++i) {
    int k = label[i];
    if (k < 0 && parts.size() == 1) k = 0;
    if (k < 0 && grid) {
      const int j = grid->nearest(fine[i]);
      if (j >= 0) k = sm_label[static_cast<std::size_t>(j)];
    }
    if (k < 0) {
      double best_d = std::numeric_limits<double>::infinity();
      for (std::size_t m = 0; m < parts.size(); ++m) {
        const double d = surfaceDistance(parts[m].fit.sq, fine[i]);
        if (d < best_d) {
          best_d = d;
          k = static_cast<int>(m);
        }
      }
    }
    out[k].indices.push_back(static_cast<int>(i));
    part_points[k].push_back(fine[i]);
  }
  // Parts were fitted on few points while splitting and merging: polish each on its own
  // (subsampled) fine points, the parts in parallel. A part is round unless its points demand
  // corners, by the same rule as the whole segment's fit: the one-sided view of a limb or a
  // trunk fits a box at the exponents' lower bound about as well as an ellipsoid.
  if (parts.size() > 1) {
    SuperquadricFitter round_bounded(round);
    if (bounds && !bounds->empty()) round_bounded.setBounds(bounds);
    detail::parallelFor(static_cast<int>(parts.size()), threads_, [&](int k) {
      if (part_points[k].empty()) return;
      Points3d data = subsample(part_points[k], params_.max_fit_points);
      Superquadric start = parts[k].fit.sq;
      // A standing composite's parts (trunk, limbs, head) are seen from one side too: each
      // also fits its points reflected about its own vertical axis (fit_bounds.h).
      if (standing) data = with_hidden_side(data, 0.0, &start, true);
      data = with_lower_part(std::move(data));
      if (round_check) {
        // Round or free is chosen the way split and merge ranks its fits (few points, few
        // iterations); only the chosen model is polished.
        const Points3d few = subsample(data, params_.split_fit_points);
        Superquadric round_start = start;
        round_start.e1 = round_start.e2 = 1.0;
        const FitResult ellipse = round_fitter.refine(
            few, round_start, std::min(params_.max_iterations, params_.split_iterations), false,
            FitMeasures::kNone);
        if (round_wins(meanSurfaceDistance(ellipse.sq, few), meanSurfaceDistance(start, few))) {
          parts[k].fit = round_bounded.refine(data, ellipse.sq, -1, true, FitMeasures::kNone);
          return;
        }
      }
      parts[k].fit = bounded.refine(data, start, -1, true, FitMeasures::kNone);
    });
  }
  for (std::size_t k = 0; k < parts.size(); ++k) {
    Indices indices = std::move(out[k].indices);
    out[k] = parts[k].fit.sq;
    out[k].indices = std::move(indices);
    out[k].segment = segment_id;
    out[k].points = static_cast<int>(out[k].indices.size());
    out[k].residual = meanSquaredResidual(out[k], part_points[k]);
  }
  return out;
}

}  // namespace novelty_detection
