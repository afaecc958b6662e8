#pragma once
/**
 * @file FetchBudget.hpp
 * @brief A per-client budget of upstream fetches: one token bucket per client address, refilled
 * at `perMinute / 60` tokens a second up to `perMinute` (a full minute's worth at once). The tile
 * service asks it once before a client's request starts an upstream fetch; cache hits, remembered
 * absences and requests that join a fetch already under way never ask. Time comes from an
 * injected Clock, so tests drive it without sleeping.
 */

#include <tellus/cache/Clock.hpp>

#include <chrono>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>

namespace tellus {

class FetchBudget {
public:
  /** `perMinute` <= 0 (or not finite): unlimited. `clock` (its steady time) outlives the
   * budget. */
  explicit FetchBudget(double perMinute, const Clock& clock = Clock::system());
  FetchBudget(const FetchBudget&) = delete;
  FetchBudget& operator=(const FetchBudget&) = delete;

  /** Takes one fetch from `client`'s budget: std::nullopt when there was one, else the time
   * until there is (the client's Retry-After); nothing is taken then. */
  std::optional<std::chrono::milliseconds> take(std::string_view client);

  bool unlimited() const noexcept { return perMinute_ <= 0; }
  double perMinute() const noexcept { return perMinute_; }
  /** Fetches refused so far (all clients). */
  std::uint64_t refused() const;
  /** Clients with a bucket now (those whose bucket is full again are forgotten now and then). */
  std::size_t clients() const;

private:
  struct Bucket {
    double tokens = 0;
    std::chrono::steady_clock::time_point last{};
  };
  struct Hash {
    using is_transparent = void;
    std::size_t operator()(std::string_view s) const noexcept {
      return std::hash<std::string_view>{}(s);
    }
  };
  double perMinute_;
  const Clock& clock_;
  mutable std::mutex mutex_;
  std::unordered_map<std::string, Bucket, Hash, std::equal_to<>> buckets_;
  std::uint64_t refused_ = 0;
};

/** What TileService::getTile asks before a request starts an upstream fetch: the budget (null:
 * none) and the client it is charged to (only read during the call). */
struct FetchGate {
  FetchBudget* budget = nullptr;
  std::string_view client;
};

} // namespace tellus
