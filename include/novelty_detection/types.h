// Shared data types of the novelty_detection core. ROS-free.
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace novelty_detection {

using PointT = pcl::PointXYZ;
using Cloud = pcl::PointCloud<PointT>;
/// Indices into a cloud (PCL convention: int).
using Indices = std::vector<int>;
/// A plain list of 3D points [m] (what the geometry code works on).
using Points3d = std::vector<Eigen::Vector3d>;

/// Whether a cloud's sensor origin (PCL's sensor_origin_) is known: finite, and either stated
/// (w = 1: given by the user, by tf, or a cloud in its own sensor frame, see setSensorOrigin)
/// or not (0, 0, 0) (a PCD VIEWPOINT; a cloud without one carries zero with w = 0). Every
/// stage that needs the viewpoint (visibility, hidden segments, disappearances, the ground
/// rule) asks this.
inline bool sensorOriginKnown(const Eigen::Vector4f& origin) {
  return origin.head<3>().allFinite() && (origin[3] == 1.0f || !origin.head<3>().isZero());
}

/// States `cloud`'s sensor origin (known even when it is (0, 0, 0): a cloud in its sensor's
/// own frame).
inline void setSensorOrigin(Cloud& cloud, const Eigen::Vector3f& origin) {
  cloud.sensor_origin_ << origin, 1.0f;
}

/// Where a reference assembled from several sweeps was observed from (a route map): per
/// sweep its sensor origin in the cloud's frame, and per point of the merged cloud the sweep
/// it came from. Empty: the cloud is one sweep, seen from its own sensor_origin_ when that
/// is known (sensorOriginKnown).
struct ReferenceViews {
  std::vector<Eigen::Vector3f> origins;  ///< per sweep [m]
  std::vector<std::uint32_t> sweep;      ///< per point of the cloud: index into origins
  bool empty() const { return origins.empty(); }
};

/// Throws std::invalid_argument unless `views` is empty or has one finite origin per sweep
/// and one valid sweep index per point of `cloud`.
void checkReferenceViews(const Cloud& cloud, const ReferenceViews& views);

/// One component of a Gaussian mixture (metres, square metres).
struct Gaussian {
  double weight = 0.0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Matrix3d cov = Eigen::Matrix3d::Identity();
};

/// A Gaussian mixture; weights sum to 1 when fitted.
struct Gmm {
  std::vector<Gaussian> components;
  std::size_t size() const { return components.size(); }
  bool empty() const { return components.empty(); }
};

/// What a fit took to hold an object up (shape/fit_bounds.h): its returns come down to the
/// floor (kPoints); its lowest line lies above the floor's band with the floor seen at its
/// foot (kFloorAtFoot); its underside was not observed and nothing was seen beneath it, so it
/// was taken to stand on the floor (kHidden: assumed); none (kNone: fitted to its points).
enum class FloorSupport : std::uint8_t { kNone = 0, kPoints, kFloorAtFoot, kHidden };
/// "none", "points", "floor_at_foot", "hidden".
const char* floorSupportName(FloorSupport support);

/// A superellipsoid (the paper's 11 parameters Lambda, eq. 2) in the fixed frame.
/// Orientation uses Z-Y-Z Euler angles (phi, theta, psi), as Jaklic et al.:
/// R = Rz(phi) * Ry(theta) * Rz(psi); a point p_world maps to the canonical frame by
/// p_sq = R^T (p_world - position).
struct Superquadric {
  Eigen::Vector3d a = Eigen::Vector3d::Constant(0.1);  ///< half sizes a1, a2, a3 [m]
  double e1 = 1.0;                                     ///< shape exponent epsilon1 (z)
  double e2 = 1.0;                                     ///< shape exponent epsilon2 (xy)
  Eigen::Vector3d euler = Eigen::Vector3d::Zero();     ///< phi, theta, psi [rad], ZYZ
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< centre [m]

  int segment = 0;                             ///< novelty segment id this part belongs to
  int points = 0;                              ///< number of points it was fitted on
  double residual = 0.0;                       ///< mean of eq. 3's squared terms over its points
  Indices indices;                             ///< input-cloud indices it explains (may be empty)
  FloorSupport support = FloorSupport::kNone;  ///< its segment's support (FloorSupport)

  Eigen::Matrix3d rotation() const;
  Eigen::Quaterniond quaternion() const;
};

/// A connected set of novel points: one changed object.
struct Segment {
  int id = 0;       ///< > 0, the label written for its points
  Indices indices;  ///< indices into the input (current) cloud
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  Eigen::Vector3d bbox_min = Eigen::Vector3d::Zero();
  Eigen::Vector3d bbox_max = Eigen::Vector3d::Zero();
  double emd_contribution = 0.0;  ///< EMD decrease owed to its Gaussians
  std::vector<int> gaussians;     ///< indices into Result::current_gmm
};

/// A segment of `cloud` with the given points and id: its centroid and bounding box.
Segment makeSegment(const Cloud& cloud, Indices indices, int id);

/// Wall time of one named stage, in milliseconds.
struct StageTiming {
  std::string stage;
  double ms = 0.0;
};

/// Each stage of `timings` once, in the order it first ran, with the total of its runs (a
/// sweep whose robot returns were found runs pre-processing, the multi-scale cut and the
/// distances to the map twice: with them, then without).
std::vector<StageTiming> stageTotals(const std::vector<StageTiming>& timings);

/// What the fine alignment stage (alignment.h) did to the current sweep before comparison.
/// `correction` maps the sweep as given onto the reference: p_map = correction * p_given.
struct AlignmentResult {
  bool attempted = false;  ///< alignment/enabled and a non-empty sweep
  bool applied = false;    ///< the correction was applied (else the sweep is left as given)
  std::string status = "disabled";  ///< "applied", or "rejected: <reason>", or "disabled"
  Eigen::Isometry3d correction = Eigen::Isometry3d::Identity();
  double translation_m = 0.0;    ///< displacement of the sensor origin (or sample centroid)
  double rotation_deg = 0.0;     ///< rotation angle of the correction
  double fitness_m = 0.0;        ///< RMS point-to-plane residual of the inliers [m]
  double inlier_fraction = 0.0;  ///< share of the sampled points that are inliers
  /// Share of the robust cost at the given pose that the correction removes (min_cost_reduction).
  double cost_reduction = 0.0;
  int samples = 0;  ///< sampled current points
  int iterations = 0;
  int degenerate_directions = 0;  ///< of 6; left unchanged (not corrected)
  double ms = 0.0;                ///< wall time of the estimate
};

/// Everything one detection produces.
struct Result {
  /// One label per input point, input order: 0 = not novel, k > 0 = segment id.
  std::vector<int> labels;
  std::vector<Segment> segments;
  std::vector<Superquadric> superquadrics;

  /// One flag per input point, input order: 1 = newly visible (in space the reference never
  /// observed, far from the map, not novel; never also labelled). See visibility.h.
  std::vector<std::uint8_t> newly_visible;
  /// One label per point of the REFERENCE cloud, its input order: 0 = still there (or not
  /// checked), k > 0 = id of the disappearance segment (the current sweep sees through it).
  /// Empty segments/superquadrics when the current cloud has no sensor origin.
  std::vector<int> disappeared_labels;
  std::vector<Segment> disappeared_segments;            ///< indices into the reference cloud
  std::vector<Superquadric> disappeared_superquadrics;  ///< `segment` = disappearance id

  Gmm current_gmm;
  std::vector<bool> novel_gaussian;  ///< per current_gmm component
  double emd_before = 0.0;
  double emd_after = 0.0;

  /// Points surviving each stage, e.g. {"input", 30000}, {"finite", 29800}, ...
  std::vector<std::pair<std::string, std::size_t>> point_counts;
  /// Stage times in the order they ran; a stage run twice is listed twice (stageTotals()).
  std::vector<StageTiming> timings;
  /// Fine alignment of the sweep. When applied, segments and superquadrics are expressed in
  /// the reference (map) frame after the correction; labels keep the input order.
  AlignmentResult alignment;

  /// The up direction used (unit, input frame) and where it came from: "given", "plane" or
  /// "nominal" (preprocess/up_direction.h).
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  std::string up_source = "given";
  /// The current sweep's floor (a x + b y + c z + d = 0 in the input frame, (a, b, c) the
  /// unit up normal) when ground removal found one; else floor_found is false and no point
  /// was removed as ground.
  bool floor_found = false;
  Eigen::Vector4d floor = Eigen::Vector4d::Zero();
  /// Whether the visibility rules ran (segmentation/visibility_check and a known reference
  /// viewpoint) and whether disappearances were looked for (visibility/disappearances and a
  /// known sensor origin of the sweep): false means "not checked", never "none".
  bool visibility_checked = false;
  bool disappearances_checked = false;
  /// The novelty distance tau used [m], and the noise model that floors it: sigma of the
  /// sweep's surfaces at the median range of its points [m], the model's name
  /// ("constant", "linear in range", "quadratic in range"; empty when too few patches).
  double tau_m = 0.0;
  double noise_sigma_m = 0.0;
  /// Share of the sweep's usable points (a sample of up to 2000) within overlapDistance of
  /// the map (input_check.h); below kMinOverlap the sweep is refused as not overlapping.
  double overlap = 1.0;
  std::string noise_model;
  /// Current points inside preprocess/ignore_regions (taken as missing), and disappearances
  /// dropped because their centroid lies inside one.
  std::size_t ignored_points = 0;
  std::size_t ignored_disappearances = 0;
  /// What the detector set aside and the user should know (e.g. points with absurd
  /// coordinates treated as missing), one sentence each.
  std::vector<std::string> warnings;

  bool hasNovelty() const { return !segments.empty(); }
};

}  // namespace novelty_detection
