#include <tellus/cache/Clock.hpp>

namespace tellus {

namespace {

constexpr std::int64_t kNsPerMs = 1'000'000;
// Where a ManualClock's steady time starts: far from zero, like a real steady clock after boot.
constexpr std::int64_t kManualSteadyStartNs = std::int64_t{3600} * 1'000'000'000;

} // namespace

UnixMillis SystemClock::now() const noexcept {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

Clock::SteadyTime SystemClock::steady() const noexcept {
  return std::chrono::steady_clock::now();
}

std::shared_ptr<const Clock> systemClock() {
  static const SystemClock clock;
  // Aliasing constructor: shares nothing, owns nothing; the static outlives every user.
  return std::shared_ptr<const Clock>(std::shared_ptr<const Clock>(), &clock);
}

UnixMillis unixMillisNow() noexcept {
  return SystemClock().now();
}

ManualClock::ManualClock(UnixMillis start) noexcept
    : wallNs_(start * kNsPerMs), steadyNs_(kManualSteadyStartNs) {}

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
