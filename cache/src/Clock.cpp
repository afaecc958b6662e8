#include <tellus/cache/Clock.hpp>

namespace tellus {

namespace {

constexpr std::int64_t kNsPerMs = 1'000'000;

const SystemClock kSystemClock;

std::int64_t nanos(std::chrono::nanoseconds d) {
  return d.count();
}

} // namespace

UnixMillis SystemClock::now() const noexcept {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

Clock::SteadyTime SystemClock::steady() const noexcept {
  return std::chrono::steady_clock::now();
}

const Clock& Clock::system() noexcept {
  return kSystemClock;
}

std::shared_ptr<const Clock> systemClock() {
  // Aliasing constructor: shares nothing, owns nothing; the static outlives every user.
  return std::shared_ptr<const Clock>(std::shared_ptr<const Clock>(), &kSystemClock);
}

UnixMillis unixMillisNow() noexcept {
  return kSystemClock.now();
}

ManualClock::ManualClock() noexcept
    : ManualClock(std::chrono::steady_clock::now(), std::chrono::system_clock::now()) {}

ManualClock::ManualClock(UnixMillis wallStart) noexcept
    : wallNs_(wallStart * kNsPerMs),
      steadyNs_(nanos(std::chrono::steady_clock::now().time_since_epoch())) {}

ManualClock::ManualClock(SteadyTime steadyStart, WallTime wallStart) noexcept
    : wallNs_(nanos(wallStart.time_since_epoch())),
      steadyNs_(nanos(steadyStart.time_since_epoch())) {}

UnixMillis ManualClock::now() const noexcept {
  return wallNs_.load(std::memory_order_acquire) / kNsPerMs;
}

Clock::SteadyTime ManualClock::steady() const noexcept {
  return SteadyTime(std::chrono::nanoseconds(steadyNs_.load(std::memory_order_acquire)));
}

void ManualClock::advance(std::chrono::nanoseconds by) noexcept {
  if (by.count() <= 0) return;
  steadyNs_.fetch_add(by.count(), std::memory_order_acq_rel);
  wallNs_.fetch_add(by.count(), std::memory_order_acq_rel);
}

void ManualClock::setNow(UnixMillis wall) noexcept {
  wallNs_.store(wall * kNsPerMs, std::memory_order_release);
}

} // namespace tellus
