// Deterministic parallel loops for the core. Internal header: only core sources include it.
#pragma once

#include <atomic>
#include <exception>
#include <functional>
#include <vector>

namespace novelty_detection {
namespace detail {

/// True on a worker thread of parallelFor() (nested loops then run serially).
inline bool& insideParallelFor() {
  thread_local bool inside = false;
  return inside;
}

/// Runs `work` on the caller and on up to `helpers` threads of a process-wide pool (started on
/// first use, kept asleep between loops), and returns when every copy that started has
/// returned. Helpers that have not started when the caller's copy returns are not waited
/// for. While another loop holds the pool, the helpers are plain threads started for this
/// loop. `work` must be safe to run concurrently and to run fewer times than asked.
void runOnPool(int helpers, const std::function<void()>& work);

/// Calls f(i) for i in [0, n) on up to `threads` threads (the caller plus threads - 1
/// workers taking items in turn from a shared counter). Items must be independent and write
/// only to their own slots, so the result does not depend on the thread count. Pool threads
/// that sleep on a condition variable rather than OpenMP: no spinning workers stealing a
/// shared machine's cores between the short loops of a superquadric recovery, and no thread
/// started per loop. Waking a sleeping helper still costs on the order of 0.1 ms on a loaded
/// machine, so a loop is worth spreading only when its items together take several times
/// that. Runs serially for threads <= 1, a single item, or inside
/// another parallelFor. Either way, the exception of the lowest failing item, if any, is
/// rethrown after all items ran.
template <class F>
void parallelFor(int n, int threads, F&& f) {
  if (n <= 0) return;
  std::vector<std::exception_ptr> errors(static_cast<std::size_t>(n));
  if (threads <= 1 || n == 1 || insideParallelFor()) {
    for (int i = 0; i < n; ++i) {
      try {
        f(i);
      } catch (...) {
        errors[static_cast<std::size_t>(i)] = std::current_exception();
      }
    }
    for (const auto& e : errors) {
      if (e) std::rethrow_exception(e);
    }
    return;
  }
  std::atomic<int> next{0};
  auto work = [&]() {
    const bool was_inside = insideParallelFor();
    insideParallelFor() = true;
    for (int i = next++; i < n; i = next++) {
      try {
        f(i);
      } catch (...) {
        errors[static_cast<std::size_t>(i)] = std::current_exception();
      }
    }
    insideParallelFor() = was_inside;
  };
  runOnPool((threads < n ? threads : n) - 1, work);
  for (const auto& e : errors) {
    if (e) std::rethrow_exception(e);
  }
}

/// Point count from which a tree over the points (the k-d tree, the multi-scale tree) grows
/// its subtrees on several threads: below it, starting the second thread costs more than it
/// saves.
constexpr int kMinPointsForParallelBuild = 20000;

/// f(i) for i in [0, n) in blocks of `block` consecutive items, each block on one thread
/// (parallelFor over the blocks): neighbouring items touch the same memory, and each item
/// must write only its own slots.
template <class F>
void parallelForBlocks(int n, int block, int threads, F&& f) {
  parallelFor((n + block - 1) / block, threads, [&](int b) {
    const int end = n - b * block < block ? n : (b + 1) * block;
    for (int i = b * block; i < end; ++i) f(i);
  });
}

}  // namespace detail
}  // namespace novelty_detection
