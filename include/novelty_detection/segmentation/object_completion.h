// Object completion: a connected piece of the sweep made mostly of novel points is a new
// object, and its other points join its segments; objects that touch are parted at the
// concave crease between them (surface_creases.h). ROS-free.
#pragma once

#include <functional>
#include <vector>

#include "novelty_detection/segmentation/novelty_segmentation.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

class CreaseTest;  // segmentation/surface_creases.h

/// Object completion: each connected piece of cloud[kept] (the sweep without its ground,
/// points linked within `link_radius_m`, not across the concave creases `creases` finds
/// where two objects touch: a point near a crease, CreaseTest::nearCrease, ends a piece and
/// leads nowhere) that holds
/// novel points of `segments` and of which those make up at least `min_share` is a new
/// object: its other points for which `may_join(index)` holds (all when it is empty) join
/// the segment they are nearest to along the piece (grown breadth first from all its
/// segments at once). A new object that stands where an old one stood has surfaces the map
/// had (within tau of it), and parts the reference could not see; they are part of the new
/// object all the same. An object that is mostly unchanged (a tin with a new mug on it, when
/// no crease parts them) stays as it is. A segment reaching into two objects parted by a
/// crease (two new boxes pushed together: kMinCreaseContacts crease points reached from
/// both) becomes one segment per object; its other parts (a segment merged across the gaps
/// between tilt lines spans several pieces) and parts under min_segment_points stay
/// together. Pieces under
/// min_segment_points never qualify. min_share >= 1 leaves the segments as they are.
/// Segments come back largest first.
/// `kept_index`: an index over cloud[kept] in that order when the caller has one (built here
/// otherwise). `creases`: over the positions in `kept` (nullptr: no creases).
constexpr int kMinCreaseContacts = 3;
void completeObjects(const Cloud& cloud, const Indices& kept, double link_radius_m,
                     double min_share, const std::function<bool(int)>& may_join,
                     std::vector<Indices>* segments,
                     const NearestNeighbourIndex* kept_index = nullptr,
                     CreaseTest* creases = nullptr, int min_segment_points = 1);

}  // namespace novelty_detection
