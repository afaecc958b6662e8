#include <tellus/proxy/FetchBudget.hpp>

#include <algorithm>
#include <cmath>
#include <iterator>

namespace tellus {

namespace {
/// Past this many clients, buckets that have filled up again are dropped (they are the same as
/// no bucket), so that a scan of many addresses cannot grow the map without bound.
constexpr std::size_t kForgetAbove = 100000;
} // namespace

FetchBudget::FetchBudget(double perMinute, const Clock& clock)
    : perMinute_(std::isfinite(perMinute) && perMinute > 0 ? perMinute : 0.0), clock_(clock) {}

std::optional<std::chrono::milliseconds> FetchBudget::take(std::string_view client) {
  if (unlimited()) return std::nullopt;
  const double capacity = std::max(1.0, perMinute_);
  const double perSecond = perMinute_ / 60.0;
  const auto now = clock_.steady();
  std::lock_guard lock(mutex_);
  if (buckets_.size() > kForgetAbove) {
    std::erase_if(buckets_, [&](const auto& kv) {
      return kv.second.tokens +
                 std::chrono::duration<double>(now - kv.second.last).count() * perSecond >=
             capacity;
    });
  }
  auto it = buckets_.find(client);
  if (it == buckets_.end()) it = buckets_.emplace(std::string(client), Bucket{capacity, now}).first;
  Bucket& b = it->second;
  const double elapsed = std::max(0.0, std::chrono::duration<double>(now - b.last).count());
  b.tokens = std::min(capacity, b.tokens + elapsed * perSecond);
  b.last = now;
  if (b.tokens >= 1.0) {
    b.tokens -= 1.0;
    return std::nullopt;
  }
  ++refused_;
  const double wait = (1.0 - b.tokens) / perSecond;
  return std::chrono::milliseconds(static_cast<std::int64_t>(std::ceil(wait * 1000.0)));
}

std::uint64_t FetchBudget::refused() const {
  std::lock_guard lock(mutex_);
  return refused_;
}

std::size_t FetchBudget::clients() const {
  std::lock_guard lock(mutex_);
  return buckets_.size();
}

} // namespace tellus
