#include "novelty_detection/process_memory.h"

#include <cstdlib>  // defines __GLIBC__ with the GNU C library

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace novelty_detection {

bool keepFreedBuffers() {
#if defined(__GLIBC__)
  // Requests below the mmap threshold come from the heap (32 MiB is the most glibc accepts
  // on 64-bit systems); the heap's top is returned to the system only beyond the trim
  // threshold. Setting them also turns off glibc's own adjustment of both.
  constexpr int kMmapThreshold = 32 << 20;
  constexpr int kTrimThreshold = 1 << 30;
  return mallopt(M_MMAP_THRESHOLD, kMmapThreshold) == 1 &&
         mallopt(M_TRIM_THRESHOLD, kTrimThreshold) == 1;
#else
  return false;
#endif
}

}  // namespace novelty_detection
