// Index subsets of a point set (split and merge). Internal header: only core sources
// include it.
#pragma once

#include <algorithm>
#include <iterator>

#include "novelty_detection/types.h"

namespace novelty_detection {
namespace detail {

/// The points at `indices`, in that order.
inline Points3d gather(const Points3d& points, const Indices& indices) {
  Points3d out;
  out.reserve(indices.size());
  for (int i : indices) out.push_back(points[static_cast<std::size_t>(i)]);
  return out;
}

/// Union of two ascending, disjoint index lists, ascending.
inline Indices sortedUnion(const Indices& a, const Indices& b) {
  Indices u;
  u.reserve(a.size() + b.size());
  std::merge(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(u));
  return u;
}

}  // namespace detail
}  // namespace novelty_detection
