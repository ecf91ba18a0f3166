#include "common/parallel.h"

#include <algorithm>
#include <condition_variable>
#include <mutex>
#include <thread>

namespace novelty_detection {
namespace detail {
namespace {

/// Sleeping threads that run one loop's work at a time (parallel.h, runOnPool()).
class Pool {
 public:
  ~Pool() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    for (auto& t : threads_) t.join();
  }

  /// False when another loop holds the pool.
  bool run(int helpers, const std::function<void()>& work) {
    std::unique_lock<std::mutex> hold(busy_, std::try_to_lock);
    if (!hold.owns_lock()) return false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      while (static_cast<int>(threads_.size()) < helpers) threads_.emplace_back([this] { loop(); });
      work_ = &work;
      wanted_ = helpers;
    }
    wake_.notify_all();
    work();
    std::unique_lock<std::mutex> lock(mutex_);
    wanted_ = 0;  // helpers not started yet are not needed: the items are taken
    done_.wait(lock, [this] { return active_ == 0; });
    work_ = nullptr;
    return true;
  }

 private:
  void loop() {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      wake_.wait(lock, [this] { return stop_ || wanted_ > 0; });
      if (stop_) return;
      --wanted_;
      ++active_;
      const std::function<void()>* work = work_;
      lock.unlock();
      (*work)();  // parallelFor's work catches every item's exception
      lock.lock();
      if (--active_ == 0) done_.notify_all();
    }
  }

  std::mutex busy_;   ///< held by the loop that uses the pool
  std::mutex mutex_;  ///< guards the fields below
  std::condition_variable wake_, done_;
  std::vector<std::thread> threads_;
  const std::function<void()>* work_ = nullptr;
  int wanted_ = 0;  ///< helpers still to start on the current work
  int active_ = 0;  ///< helpers running it
  bool stop_ = false;
};

}  // namespace

void runOnPool(int helpers, const std::function<void()>& work) {
  if (helpers > 0) {
    static Pool pool;
    if (pool.run(helpers, work)) return;
  }
  std::vector<std::thread> threads;
  threads.reserve(static_cast<std::size_t>(std::max(0, helpers)));
  for (int t = 0; t < helpers; ++t) threads.emplace_back(work);
  work();
  for (auto& t : threads) t.join();
}

}  // namespace detail
}  // namespace novelty_detection
