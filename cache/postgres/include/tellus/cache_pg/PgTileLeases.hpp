#pragma once
/**
 * @file PgTileLeases.hpp
 * @brief Single-flight leases in PostgreSQL (issue 27; the protocol is in TileLeases.hpp).
 *
 * - A lease is a session-level advisory lock, pg_try_advisory_lock(leaseNumber(key)), taken on one
 *   connection of this process: never waited for in the server, and lost with the session when the
 *   process dies (no lease row to expire, no stale-lock timeout to sit out).
 * - release() unlocks and sends NOTIFY tellus_tiles '<number>' in one statement, after the tile's
 *   row is committed.
 * - A second connection LISTENs on tellus_tiles in a thread of its own (poll(2) on the socket, no
 *   polling of the server) and calls the waiters of the numbers it hears. A waiter whose holder
 * died hears nothing; its `recheck` wakes it to try the lock again, which then succeeds.
 * - A connection that breaks is made again on next use; meanwhile leases are Unavailable (the
 *   caller fetches alone), so a database restart costs duplicated fetches, never an error.
 */

#include <tellus/cache/TileLeases.hpp>
#include <tellus/cache_pg/PgTileIndex.hpp>

#include <expected>
#include <memory>

namespace tellus {

/** Connects both connections and starts listening. */
std::expected<std::shared_ptr<ITileLeases>, CacheError>
openPgTileLeases(const PgConnectOptions& options);

} // namespace tellus
