// Conversions between sensor_msgs/PointCloud2 and the core's Cloud.
#pragma once

#include <sensor_msgs/PointCloud2.h>

#include <vector>

#include "novelty_detection/io/cloud_io.h"
#include "novelty_detection/types.h"

namespace novelty_detection {

/// Converts any PointCloud2 with FLOAT32 x, y, z fields (any offsets, point_step, row_step,
/// organised or not, either endianness) into a Cloud with one point per input point, in
/// input order (row-major). NaN/inf points are kept so that labels stay aligned with the
/// input. Throws std::invalid_argument naming the problem: a missing x/y/z field, a field
/// that is not FLOAT32 or has count 0, a field past point_step, row_step < width *
/// point_step, or data shorter than height * row_step.
Cloud fromPointCloud2(const sensor_msgs::PointCloud2& msg);

/// A PointCloud2 with fields x, y, z (FLOAT32), label (UINT32) and rgb (rviz's packed
/// RGB8: the segment's colour, segmentColour, as on its superquadrics; grey for label 0), in
/// the host's byte order, dense layout. With `only_labelled`, keeps the points with label > 0;
/// otherwise every point (the output is then organised like `cloud`: height 1, width = cloud size).
/// Throws std::invalid_argument when labels.size() != cloud.size().
sensor_msgs::PointCloud2 toLabelledPointCloud2(const Cloud& cloud, const std::vector<int>& labels,
                                               const std_msgs::Header& header, bool only_labelled);

/// Plain x, y, z PointCloud2 of a Cloud (for the reference map, assembled sweeps and cloud
/// files); an organised cloud (height > 1, width x height points) keeps its layout.
sensor_msgs::PointCloud2 toPointCloud2(const Cloud& cloud, const std_msgs::Header& header);

/// The file's cloud with its stored viewpoint (PCD VIEWPOINT) as sensor_origin_ and
/// sensor_orientation_, where the pipeline's free-space check reads it.
Cloud withViewpoint(const CloudFile& file);
/// The pose held in a cloud's sensor_origin_ / sensor_orientation_ (for saving it).
Eigen::Isometry3d viewpointOf(const Cloud& cloud);

}  // namespace novelty_detection
