#pragma once
/**
 * @file Clock.hpp
 * @brief Time as tellus reads it, injected so that tests move it by hand instead of sleeping.
 *
 * Two times, as the standard library has them:
 * - wall time, `now()`: milliseconds since the Unix epoch (std::chrono::system_clock). What is
 *   stored and compared with stored values: a tile's fetched-at, last access and expiry, a
 *   dataset's creation, an absent marker's retry-after, HTTP dates. It may jump (NTP, an operator).
 * - steady time, `steady()`: std::chrono::steady_clock. What intervals and deadlines are measured
 *   with: re-probing a full disk, re-checking a held-open file, looking for other writers'
 *   commits, flushing access times. It never goes back.
 *
 * Implementations: SystemClock (the two real clocks; Clock::system() and systemClock() are one)
 * and ManualClock (tests: both times stand still until advanced). Every method may be called from
 * any thread.
 * Waiting itself (a condition variable's timeout, a busy loop on another process's lock) is not
 * the clock's business: it still takes real time.
 */

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>

namespace tellus {

/** Milliseconds since the Unix epoch (the cache's clock unit). */
using UnixMillis = std::int64_t;

class Clock {
public:
  using SteadyTime = std::chrono::steady_clock::time_point;
  using WallTime = std::chrono::system_clock::time_point;

  virtual ~Clock() = default;
  /** Wall time in milliseconds since the Unix epoch. */
  virtual UnixMillis now() const noexcept = 0;
  /** Monotonic time, for intervals and deadlines. */
  virtual SteadyTime steady() const noexcept = 0;

  /** now() as a system_clock time point (HTTP dates). */
  WallTime wallNow() const noexcept { return WallTime(std::chrono::milliseconds(now())); }
  /** The process's clocks (a SystemClock that lives as long as the program). */
  static const Clock& system() noexcept;
};

/** std::chrono::system_clock and std::chrono::steady_clock. */
class SystemClock final : public Clock {
public:
  UnixMillis now() const noexcept override;
  SteadyTime steady() const noexcept override;
};

/** One SystemClock for everyone (never null, lives as long as the program). */
std::shared_ptr<const Clock> systemClock();

/** Milliseconds since the Unix epoch, now, from the system clock. */
UnixMillis unixMillisNow() noexcept;

/**
 * A clock that stands still until advance() or setNow() moves it (tests). Both times start at the
 * present unless given; advance() moves both by the same amount. Reads are lock-free and safe
 * while another thread moves it.
 */
class ManualClock final : public Clock {
public:
  /** Both times start at the present of the real clocks. */
  ManualClock() noexcept;
  /** Wall time starts at `wallStart` (a fixed date makes a test independent of the day it runs),
   * steady time at the present. */
  explicit ManualClock(UnixMillis wallStart) noexcept;
  ManualClock(SteadyTime steadyStart, WallTime wallStart) noexcept;
  UnixMillis now() const noexcept override;
  SteadyTime steady() const noexcept override;

  /** Moves wall and steady time forward by `by` (a negative `by` is ignored: time never goes
   * back here; use setNow() for a wall clock stepped backwards). */
  void advance(std::chrono::nanoseconds by) noexcept;
  /** Sets wall time alone, as an operator or NTP would; steady time does not move. */
  void setNow(UnixMillis wall) noexcept;

private:
  std::atomic<std::int64_t> wallNs_;
  std::atomic<std::int64_t> steadyNs_;
};

} // namespace tellus
