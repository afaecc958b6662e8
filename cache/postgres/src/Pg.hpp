#pragma once
/**
 * @file Pg.hpp
 * @brief The small libpq layer of tellus::cache_pg: owned connections and results, text
 * parameters, values read back, and libpq's errors as CacheError (SQLSTATE 53100 disk full ->
 * DiskFull, XX001 data corrupted -> Corrupt, the rest Io). Values travel as text: integers in
 * decimal, doubles in their shortest exact form both ways (std::to_chars / from_chars; the server's
 * float8 output is shortest-exact since PostgreSQL 12).
 */

#include <tellus/cache/CacheError.hpp>
#include <tellus/cache_pg/PgTileIndex.hpp>

#include <cstdint>
#include <expected>
#include <libpq-fe.h>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace tellus::pg {

struct ConnDeleter {
  void operator()(PGconn* c) const noexcept { PQfinish(c); }
};
struct ResultDeleter {
  void operator()(PGresult* r) const noexcept { PQclear(r); }
};
using ConnPtr = std::unique_ptr<PGconn, ConnDeleter>;
using ResultPtr = std::unique_ptr<PGresult, ResultDeleter>;

/** Statement parameters $1..$n as text; nullopt is SQL NULL. */
class Params {
public:
  Params& add(std::int64_t v);
  Params& add(double v);
  Params& add(std::string_view v);
  Params& add(const std::optional<std::int64_t>& v);
  Params& addNull();
  int size() const noexcept { return static_cast<int>(values_.size()); }
  /** Pointers for PQexecParams (valid while this lives and is not changed). */
  std::vector<const char*> pointers() const;

private:
  std::vector<std::optional<std::string>> values_;
};

/** Connects (libpq reads PGPASSWORD/PGPASSFILE itself; `passwordFile` is read here). */
std::expected<ConnPtr, CacheError> connect(const PgConnectOptions& options);

/** Runs one statement (without params: PQexec, which may run several); a result that is neither
 * COMMAND_OK nor TUPLES_OK is an error that says `what`. */
std::expected<ResultPtr, CacheError>
exec(PGconn* conn, const char* sql, const Params& params, const char* what);
std::expected<ResultPtr, CacheError> exec(PGconn* conn, const char* sql, const char* what);

/** The error of a failed statement (`result` may be null: the connection's message). */
CacheError errorFrom(PGconn* conn, const PGresult* result, std::string_view what);

/** True when the connection is gone (the caller reconnects). */
bool broken(PGconn* conn) noexcept;

std::int64_t i64(const PGresult* r, int row, int col);
double f64(const PGresult* r, int row, int col);
std::string text(const PGresult* r, int row, int col);
bool isNull(const PGresult* r, int row, int col);
std::optional<std::int64_t> optI64(const PGresult* r, int row, int col);

} // namespace tellus::pg
