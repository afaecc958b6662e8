#pragma once
/**
 * @file Clock.hpp
 * @brief Time as the proxy reads it, injected: a steady clock for intervals and deadlines (retry
 * backoff, the circuit breaker, Retry-After pauses, rate limits) and a wall clock for what is
 * written down or compared with HTTP dates (fetch times, Retry-After dates). Production code uses
 * Clock::system(); tests use a ManualClock and move time on by hand, so that no test sleeps
 * against an interval.
 *
 * Declared in proxy for now: cache/ gets a clock of its own in the same phase (issue 22), and the
 * two are to become one, in cache/ (the inner module), when they meet.
 */

#include <chrono>
#include <cstdint>
#include <mutex>

namespace tellus {

class Clock {
public:
  virtual ~Clock() = default;
  /** Steady time: never goes back, unrelated to the calendar. */
  virtual std::chrono::steady_clock::time_point now() const = 0;
  /** Wall time (UTC). */
  virtual std::chrono::system_clock::time_point wallNow() const = 0;
  /** Wall time in milliseconds since the Unix epoch (the cache's unit, UnixMillis). */
  std::int64_t wallMillis() const {
    return std::chrono::duration_cast<std::chrono::milliseconds>(wallNow().time_since_epoch())
        .count();
  }
  /** The process's clocks: std::chrono::steady_clock and std::chrono::system_clock. */
  static const Clock& system() noexcept;
};

/** std::chrono::steady_clock and std::chrono::system_clock. */
class SystemClock final : public Clock {
public:
  std::chrono::steady_clock::time_point now() const override {
    return std::chrono::steady_clock::now();
  }
  std::chrono::system_clock::time_point wallNow() const override {
    return std::chrono::system_clock::now();
  }
};

inline const Clock& Clock::system() noexcept {
  static const SystemClock clock;
  return clock;
}

/**
 * @brief A clock that moves only when told to (tests). Both times start where the caller says
 * (by default the steady clock's and the wall clock's present) and advance() moves both by the
 * same amount. Thread safe: any thread may read it while another advances it.
 */
class ManualClock final : public Clock {
public:
  ManualClock() : ManualClock(std::chrono::steady_clock::now(), std::chrono::system_clock::now()) {}
  ManualClock(std::chrono::steady_clock::time_point steadyStart,
              std::chrono::system_clock::time_point wallStart)
      : steady_(steadyStart), wall_(wallStart) {}

  std::chrono::steady_clock::time_point now() const override {
    std::lock_guard lock(mutex_);
    return steady_;
  }
  std::chrono::system_clock::time_point wallNow() const override {
    std::lock_guard lock(mutex_);
    return wall_;
  }
  /** Moves both clocks on by `d` (d >= 0). */
  void advance(std::chrono::nanoseconds d) {
    std::lock_guard lock(mutex_);
    steady_ += std::chrono::duration_cast<std::chrono::steady_clock::duration>(d);
    wall_ += std::chrono::duration_cast<std::chrono::system_clock::duration>(d);
  }

private:
  mutable std::mutex mutex_;
  std::chrono::steady_clock::time_point steady_;
  std::chrono::system_clock::time_point wall_;
};

} // namespace tellus
