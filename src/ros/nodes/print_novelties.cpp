// print_novelties: prints every NoveltyArray it receives (each novelty with its
// superquadrics) and exits after ~count messages or ~timeout wall seconds.
#include <ros/ros.h>

#include <cstdio>

#include "novelty_detection/NoveltyArray.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "print_novelties");
  ros::NodeHandle nh, pnh("~");
  const int count = pnh.param("count", 0);           // 0: never stop on count
  const double timeout = pnh.param("timeout", 0.0);  // 0: no timeout
  int received = 0;
  ros::Subscriber sub = nh.subscribe<novelty_detection::NoveltyArray>(
      "novelties", 10, [&](const novelty_detection::NoveltyArray::ConstPtr& m) {
        ++received;
        std::printf("sweep %d at t=%.3f (%s): %zu novelties, EMD %.4f -> %.4f, %.1f ms\n", received,
                    m->header.stamp.toSec(), m->header.frame_id.c_str(), m->novelties.size(),
                    m->emd_before, m->emd_after, 1000.0 * m->processing_time);
        for (const auto& n : m->novelties) {
          std::printf(
              "  novelty %d: %u points, centroid (%.2f, %.2f, %.2f) m, box (%.2f, %.2f, %.2f)"
              "..(%.2f, %.2f, %.2f) m, EMD share %.4f, track %u seen %u time(s)%s\n",
              n.id, n.points, n.centroid.x, n.centroid.y, n.centroid.z, n.bbox_min.x, n.bbox_min.y,
              n.bbox_min.z, n.bbox_max.x, n.bbox_max.y, n.bbox_max.z, n.emd_contribution,
              n.track_id, n.times_seen, n.confirmed ? ", confirmed" : "");
          for (const auto& sq : n.superquadrics) {
            std::printf(
                "    superquadric: a = (%.3f, %.3f, %.3f) m, e1 = %.2f, e2 = %.2f, at (%.2f, "
                "%.2f, %.2f) m, euler ZYZ (%.2f, %.2f, %.2f) rad, %u points, residual %.2e\n",
                sq.a[0], sq.a[1], sq.a[2], sq.e1, sq.e2, sq.pose.position.x, sq.pose.position.y,
                sq.pose.position.z, sq.euler[0], sq.euler[1], sq.euler[2], sq.points, sq.residual);
          }
        }
        if (m->disappearances_checked) {
          std::printf("  disappearances: %zu\n", m->disappeared.size());
          for (const auto& d : m->disappeared)
            std::printf("  disappeared %d: %u reference points, centroid (%.2f, %.2f, %.2f) m\n",
                        d.id, d.points, d.centroid.x, d.centroid.y, d.centroid.z);
        } else {
          std::printf("  disappearances: not checked (no sensor pose for the sweep)\n");
        }
        if (!m->visibility_checked)
          std::printf("  visibility rules: off (the reference has no viewpoint)\n");
        std::fflush(stdout);
      });
  const ros::WallTime start = ros::WallTime::now();
  while (ros::ok()) {
    ros::spinOnce();
    if (count > 0 && received >= count) break;
    if (timeout > 0.0 && (ros::WallTime::now() - start).toSec() > timeout) {
      std::printf("print_novelties: %d result(s) after %.0f s, stopping\n", received, timeout);
      break;
    }
    ros::WallDuration(0.05).sleep();
  }
  return received > 0 ? 0 : 1;
}
