#pragma once
// The index schema and its migrations (private to cache/).

#include <tellus/cache/CacheError.hpp>

#include <sqlite3.h>

#include <expected>

namespace tellus::schema {

/** The version written by this build (PRAGMA user_version). */
inline constexpr int kVersion = 3;

/** Creates the schema in an empty database or migrates an older one, in one transaction.
 * Fails with CacheErrc::Schema for a newer version or a database that is not a tellus index. */
std::expected<void, CacheError> ensure(sqlite3* db);

} // namespace tellus::schema
