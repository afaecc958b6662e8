#pragma once
/** @file PgSchema.hpp @brief The PostgreSQL index's tables, created or checked at open. */

#include "Pg.hpp"

namespace tellus::pg {

/** Schema version of this tellus (the row `schema_version` of `tellus_meta`). */
inline constexpr int kSchemaVersion = 1;

/** Creates the tables when missing (one creator at a time: an advisory lock), or checks that the
 * version is one this tellus reads; read-only: checks only. */
std::expected<void, CacheError> ensureSchema(PGconn* conn, bool readOnly);

} // namespace tellus::pg
