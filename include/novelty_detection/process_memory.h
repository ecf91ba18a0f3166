// How a process running the detector manages its heap. ROS-free.
#pragma once

namespace novelty_detection {

/// Process-wide and idempotent: freed buffers of any size stay in the heap for the next
/// allocation instead of going back to the system. A detection allocates and frees buffers
/// of megabytes stage after stage (cloud copies, range images, neighbour trees); by default
/// glibc maps each one afresh and unmaps it on free, so every page is faulted in again, a
/// fifth of the time on a 300k-point cloud. The process then keeps its peak size. Returns
/// false where the C library offers no such setting (nothing changes).
bool keepFreedBuffers();

}  // namespace novelty_detection
