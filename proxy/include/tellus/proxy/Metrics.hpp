#pragma once
/**
 * @file Metrics.hpp
 * @brief Counters of `tellus serve` and their Prometheus text exposition (format 0.0.4) at
 * `/metrics`: requests by protocol and status, bytes, in-flight, tile outcomes per layer (hit,
 * miss, stale, offline, absent, error, refused), upstream requests, errors by kind, latency
 * histograms, breaker state, the cache's size and the per-client fetch budget.
 *
 * Counting is lock-free (relaxed atomics in fixed arrays): the hit path pays a few increments.
 */

#include <tellus/proxy/Fetcher.hpp>

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace tellus {

enum class Protocol : std::uint8_t { Wms, WorldWind, Static, Wmts, Page, Metrics, Other };
inline constexpr std::size_t kProtocolCount = 7;
const char* toString(Protocol p) noexcept;

/** What a tile request came to (the X-Cache header, plus the non-tile answers; Refused: the
 * client's budget of upstream fetches was spent). */
enum class TileOutcome : std::uint8_t { Hit, Miss, Stale, Offline, Absent, Error, Refused };
inline constexpr std::size_t kTileOutcomeCount = 7;
const char* toString(TileOutcome o) noexcept;

/** A bounded local tier in front of a shared store (`cache.s3.local_tier_limit`, issue 27). */
struct LocalTierMetrics {
  std::uint64_t bytes = 0;     ///< of the local copies recorded
  std::uint64_t evictions = 0; ///< local copies removed for the limit since the start
};

/** The cache as /metrics shows it: whether it stores tiles, how many fetched tiles it refused for
 * lack of space (they were served all the same), and the free space under its root. */
struct CacheHealthMetrics {
  bool writable = true;
  std::uint64_t refusedStores = 0;
  /// Fetched tiles the cache did not store, kept in memory (TileServiceOptions::keepUnstoredBytes).
  std::uint64_t keptUnstoredTiles = 0;
  std::uint64_t keptUnstoredBytes = 0;
  std::uint64_t servedKeptUnstored = 0; ///< answers from them, none asked of the upstream
  std::uint64_t storedLater = 0;        ///< of them stored once the cache took tiles again
  /// A shared index (cache.index, issue 27): whether its server answers; nullopt: none.
  std::optional<bool> sharedIndexUp;
  std::uint64_t leaseWaits = 0;         ///< misses that waited for another instance's fetch
  std::uint64_t servedWithoutIndex = 0; ///< requests answered from the store alone (index down)
  std::optional<std::uint64_t> freeBytes;
  std::optional<std::uint64_t> freeInodes;
  std::optional<LocalTierMetrics> localTier; ///< nullopt: none, or not bounded
};

/** The per-client budget of upstream fetches (FetchBudget) as /metrics shows it. */
struct FetchBudgetMetrics {
  double perMinute = 0;      ///< 0: unlimited
  std::uint64_t refused = 0; ///< fetches refused, all clients
  std::size_t clients = 0;   ///< client addresses with a budget held now
};

/** One upstream as /metrics shows it. */
struct UpstreamMetrics {
  std::string name;
  Fetcher::Stats stats;
};

class ProxyMetrics {
public:
  explicit ProxyMetrics(std::vector<std::string> layerNames);

  void requestStarted(Protocol p) noexcept;
  void requestFinished(Protocol p, int status, std::uint64_t bodyBytes) noexcept;
  /** `layer` indexes the names given at construction; others are ignored. */
  void tile(std::size_t layer, TileOutcome outcome) noexcept;
  /** A composed map sampled `decoded` tiles it decoded and `kept` ones that came decoded from
   * the composer's decoded-tile cache. */
  void composedTiles(std::uint64_t decoded, std::uint64_t kept) noexcept;
  /** A composed answer of `output` texels (width x height; 0 for a 304 or an error) made from
   * tiles of `fromUpstream` texels fetched from the upstream for it, `fromCache` texels found
   * cached and `joined` texels fetched for another answer whose fetch it joined in flight (issue
   * 29: what a composed map costs upstream against what it returns). */
  void composedTexels(std::uint64_t output,
                      std::uint64_t fromUpstream,
                      std::uint64_t fromCache,
                      std::uint64_t joined = 0) noexcept;

  /** The exposition: these counters plus the upstreams' and the cache's figures, the bytes
   * held by the decoded-tile cache and the per-client fetch budget. */
  std::string render(const std::vector<UpstreamMetrics>& upstreams,
                     std::optional<std::int64_t> cacheBytes,
                     std::uint64_t decodedTileCacheBytes = 0,
                     const FetchBudgetMetrics& budget = {},
                     const std::optional<CacheHealthMetrics>& cacheHealth = std::nullopt) const;

  /** HTTP statuses counted one by one; any other is counted as "other". */
  static constexpr std::array<int, 14> kStatuses{
      200, 204, 304, 400, 403, 404, 405, 413, 429, 431, 500, 502, 503, 504};

private:
  // The sections of render(), in order.
  void renderHttp(std::string& out) const;
  void renderTiles(std::string& out) const;
  static void renderUpstreams(std::string& out, const std::vector<UpstreamMetrics>& upstreams);
  static void renderCache(std::string& out,
                          std::optional<std::int64_t> cacheBytes,
                          const std::optional<CacheHealthMetrics>& cacheHealth);
  void renderComposer(std::string& out, std::uint64_t decodedTileCacheBytes) const;
  static void renderBudget(std::string& out, const FetchBudgetMetrics& budget);

  using Counter = std::atomic<std::uint64_t>;
  std::vector<std::string> layers_;
  std::array<std::array<Counter, kStatuses.size() + 1>, kProtocolCount> requests_{};
  std::array<Counter, kProtocolCount> bytes_{};
  std::array<std::atomic<std::int64_t>, kProtocolCount> inFlight_{};
  std::unique_ptr<std::array<Counter, kTileOutcomeCount>[]> tiles_;
  Counter composedDecoded_{0}, composedKept_{0};
  Counter outputTexels_{0}, upstreamTexels_{0}, cachedTexels_{0}, joinedTexels_{0};
};

/** A Prometheus label value with `\`, `"` and newlines escaped. */
std::string prometheusLabel(std::string_view value);

} // namespace tellus
