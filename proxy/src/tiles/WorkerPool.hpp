#pragma once
// A fixed set of worker threads for CPU work (rendering local rasters, validating and storing
// fetched tiles, composing maps) so that neither the HTTP loops nor the fetcher thread wait for it.

#include <algorithm>
#include <cerrno>
#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <sys/resource.h>
#include <thread>
#include <unistd.h>
#include <vector>

namespace tellus {

class WorkerPool {
public:
  /** `n` threads whose nice value is the process's plus `nice` (0: the same; Linux sets it per
   * thread, a value it refuses is ignored). `tellus render` and `view` run the tile service's
   * workers at a lower priority than the thread that draws. */
  explicit WorkerPool(int n, int nice = 0) {
    for (int i = 0; i < std::max(1, n); ++i)
      threads_.emplace_back([this, nice] {
        if (nice != 0) {
          const auto self = static_cast<id_t>(gettid());
          errno = 0;
          const int now = getpriority(PRIO_PROCESS, self);
          if (errno == 0) (void)setpriority(PRIO_PROCESS, self, std::clamp(now + nice, -20, 19));
        }
        loop();
      });
  }
  ~WorkerPool() {
    {
      std::lock_guard lock(m_);
      stop_ = true;
    }
    cv_.notify_all();
    for (auto& t : threads_)
      t.join();
  }
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  void post(std::function<void()> job) {
    {
      std::lock_guard lock(m_);
      jobs_.push_back(std::move(job));
    }
    cv_.notify_one();
  }

private:
  void loop() {
    for (;;) {
      std::function<void()> job;
      {
        std::unique_lock lock(m_);
        cv_.wait(lock, [this] { return stop_ || !jobs_.empty(); });
        if (jobs_.empty()) return; // stopping with nothing left to do
        job = std::move(jobs_.front());
        jobs_.pop_front();
      }
      job();
    }
  }
  std::mutex m_;
  std::condition_variable cv_;
  std::deque<std::function<void()>> jobs_;
  bool stop_ = false;
  std::vector<std::thread> threads_;
};

} // namespace tellus
