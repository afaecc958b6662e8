#pragma once
/**
 * @file PgTileIndex.hpp
 * @brief The tile index in PostgreSQL (issue 27): the SQLite index's rows, datasets, counters and
 * selections in a database that several tellus processes on several machines share.
 *
 * The tables are the SQLite index's (cache/src/sqlite/Schema.cpp): `datasets`, `tiles` (one row
 * per tile, present or absent upstream) and `usage` (per-dataset counters kept by triggers, so
 * totals never scan). They are created at the first open, under an advisory lock so that several
 * instances starting at once create them once. Reads come from pooled connections (autocommit:
 * committed state only); writes from one connection per index, inside BEGIN/COMMIT with one level
 * of SAVEPOINT, as ITileIndex asks. Other processes' commits are noticed by the snapshot's xmax
 * moving past this connection's own transactions.
 *
 * Credentials: the connection string (`postgresql://user@host:port/db?...`) must not hold a
 * password; the password comes from libpq's environment (PGPASSWORD, PGPASSFILE, ~/.pgpass) or
 * from `passwordFile` (its first line). Every message this module makes names the server by
 * redactConninfo() only, and libpq's own messages never contain the password.
 */

#include <tellus/cache/TileIndex.hpp>

#include <chrono>
#include <expected>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

namespace tellus {

/** How to reach a PostgreSQL server. */
struct PgConnectOptions {
  std::string conninfo; ///< a postgresql:// URI or key=value string, without a password
  std::optional<std::filesystem::path> passwordFile; ///< first line = the password
  std::chrono::seconds connectTimeout{5};
};

struct PgTileIndexOptions {
  PgConnectOptions connect;
  int readConnections = 4;     ///< idle read connections kept
  int maxReadConnections = 16; ///< read connections open at once (more readers wait)
  bool readOnly = false;       ///< no writes: the schema must exist
};

/** True for `postgresql://` and `postgres://` URIs: what `cache.index` takes as PostgreSQL. */
bool isPostgresUri(std::string_view text);

/** The connection string as it may be shown: the password of a URI's user info and any
 * `password=` parameter replaced by `***`. */
std::string redactConninfo(std::string_view conninfo);

/** Refuses a connection string that carries a password (without repeating it), or that libpq
 * cannot parse. */
std::expected<void, CacheError> checkConninfo(std::string_view conninfo);

/** Connects, creates the schema when missing (not read-only) and returns the index. Errors name the
 * server by redactConninfo(). */
std::expected<std::unique_ptr<ITileIndex>, CacheError>
openPgTileIndex(const PgTileIndexOptions& options);

} // namespace tellus
