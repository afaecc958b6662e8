#pragma once
/**
 * @file TileLeases.hpp
 * @brief Single flight across processes (issue 27): before a miss is fetched upstream, the fetcher
 * takes a lease on the tile (or metatile) it will fetch; another process that misses the same one
 * meanwhile learns that the lease is held and waits for its release, then reads the tile from the
 * shared index and store instead of fetching it again.
 *
 * Within one process the proxy's flights (proxy/src/tiles/TileFlights.cpp) already join requests
 * for one tile; leases extend that to every process sharing an index. Implementations:
 * - localTileLeases(): every lease is granted at once, nothing is shared: one machine, today's
 *   behaviour (the embedded default);
 * - PostgreSQL (tellus/cache_pg/PgTileLeases.hpp): session advisory locks, so a holder that dies
 *   loses its leases with its connection; waiters are woken by LISTEN/NOTIFY.
 *
 * The protocol, for one flight:
 *   acquireOrWait(key, recheck, retry):
 *     Acquired    -> fetch, store (the index row committed), then release(key): waiters wake
 *                    (and after each tile of a metatile stored, progress(key): they wake too);
 *     Waiting     -> `retry` is called once, on another thread, when the lease is released or
 *                    after `recheck` (a holder that died wakes nobody); look at the cache again,
 *                    and if the tile is still missing, call acquireOrWait again;
 *     Unavailable -> the lease service cannot be reached: fetch anyway (one flight per process).
 * A waiter is registered before the lock is tried, so a release between the two is never missed.
 */

#include <tellus/cache/TileKey.hpp>

#include <chrono>
#include <functional>
#include <memory>
#include <string>

namespace tellus {

/** What one lease is on: a dataset (by its folder, the same in every process) and a tile or a
 * metatile's first tile. */
struct LeaseKey {
  std::string folder;
  TileKey key;
};

enum class LeaseOutcome { Acquired, Waiting, Unavailable };

class ITileLeases {
public:
  virtual ~ITileLeases() = default;
  /** Takes the lease, or registers `retry` to be called once when it is released elsewhere or
   * after `recheck`. `retry` runs on a thread of the implementation: hand work over, do not block.
   */
  virtual LeaseOutcome acquireOrWait(const LeaseKey& key,
                                     std::chrono::milliseconds recheck,
                                     std::function<void()> retry) = 0;
  /** Gives back a lease taken here and wakes its waiters in every process. */
  virtual void release(const LeaseKey& key) = 0;
  /** Part of what a lease held here covers is stored (a tile of its metatile): its waiters in
   * every process are woken now, as by a release (they look at the cache again and wait again for
   * what is still missing), and the lease stays held. Nothing to do where nothing waits. */
  virtual void progress(const LeaseKey& key) { (void)key; }
  /** Whether the shared lease service answers (false: leases are Unavailable). */
  virtual bool healthy() const = 0;
};

/** One process alone: every lease is granted, nothing waits. */
std::shared_ptr<ITileLeases> localTileLeases();

/** The 64-bit lease number of a key (stable across processes and machines). */
std::int64_t leaseNumber(const LeaseKey& key) noexcept;

} // namespace tellus
