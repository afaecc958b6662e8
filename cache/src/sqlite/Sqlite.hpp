#pragma once
// Private RAII helpers over the SQLite C API (sqlite3.h never leaves cache/src).

#include <tellus/cache/CacheError.hpp>

#include <sqlite3.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

namespace tellus::sql {

struct DbCloser {
  void operator()(sqlite3* db) const noexcept { sqlite3_close_v2(db); }
};
using DbPtr = std::unique_ptr<sqlite3, DbCloser>;

struct StmtFinalizer {
  void operator()(sqlite3_stmt* s) const noexcept { sqlite3_finalize(s); }
};
using StmtPtr = std::unique_ptr<sqlite3_stmt, StmtFinalizer>;

/** Maps an SQLite result code to the cache's error taxonomy. */
inline CacheErrc errcFor(int rc) noexcept {
  switch (rc & 0xFF) {
  case SQLITE_FULL:
    return CacheErrc::DiskFull;
  case SQLITE_CORRUPT:
  case SQLITE_NOTADB:
    return CacheErrc::Corrupt;
  case SQLITE_READONLY:
    return CacheErrc::ReadOnly;
  default:
    return CacheErrc::Io;
  }
}

/** The error of a failed call: SQLITE_FULL, and an I/O error whose system errno is ENOSPC, EDQUOT
 * or EFBIG (a WAL or shared-memory file that cannot grow), are DiskFull. */
inline CacheError errorFrom(sqlite3* db, int rc, std::string_view what) {
  std::string msg(what);
  msg += ": ";
  msg += db ? sqlite3_errmsg(db) : sqlite3_errstr(rc);
  CacheErrc code = errcFor(rc);
  if (db && (rc & 0xFF) == SQLITE_IOERR) {
    const int err = sqlite3_system_errno(db);
    if (err == ENOSPC || err == EDQUOT || err == EFBIG) {
      code = CacheErrc::DiskFull;
      msg += " (";
      msg += std::strerror(err);
      msg += ')';
    }
  }
  return CacheError{code, std::move(msg)};
}

/** A prepared statement that resets itself when a use ends (see Use). */
class Stmt {
public:
  Stmt() = default;
  Stmt(sqlite3* db, const char* sqlText) : db_(db) {
    sqlite3_stmt* s = nullptr;
    rc_ = sqlite3_prepare_v3(db, sqlText, -1, SQLITE_PREPARE_PERSISTENT, &s, nullptr);
    stmt_.reset(s);
  }
  bool ok() const noexcept { return rc_ == SQLITE_OK && stmt_ != nullptr; }
  int prepareRc() const noexcept { return rc_; }
  sqlite3_stmt* get() const noexcept { return stmt_.get(); }
  sqlite3* db() const noexcept { return db_; }

  /** Scoped use: binds, steps, and resets + clears bindings on destruction. */
  class Use {
  public:
    explicit Use(const Stmt& s) : s_(s.get()) {}
    ~Use() {
      sqlite3_reset(s_);
      sqlite3_clear_bindings(s_);
    }
    Use(const Use&) = delete;
    Use& operator=(const Use&) = delete;
    Use& bind(int i, std::int64_t v) {
      sqlite3_bind_int64(s_, i, v);
      return *this;
    }
    Use& bind(int i, double v) {
      sqlite3_bind_double(s_, i, v);
      return *this;
    }
    Use& bind(int i, std::string_view v) {
      sqlite3_bind_text(s_, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT);
      return *this;
    }
    Use& bindBlob(int i, const void* data, std::size_t size) {
      sqlite3_bind_blob64(s_, i, data, static_cast<sqlite3_uint64>(size), SQLITE_TRANSIENT);
      return *this;
    }
    Use& bindNull(int i) {
      sqlite3_bind_null(s_, i);
      return *this;
    }
    Use& bind(int i, const std::optional<std::int64_t>& v) { return v ? bind(i, *v) : bindNull(i); }
    int step() { return sqlite3_step(s_); }
    std::int64_t i64(int c) const { return sqlite3_column_int64(s_, c); }
    double f64(int c) const { return sqlite3_column_double(s_, c); }
    bool isNull(int c) const { return sqlite3_column_type(s_, c) == SQLITE_NULL; }
    /** A blob column's bytes (valid until the next step). */
    std::pair<const std::byte*, std::size_t> blob(int c) const {
      const auto* p = static_cast<const std::byte*>(sqlite3_column_blob(s_, c));
      return {p, static_cast<std::size_t>(sqlite3_column_bytes(s_, c))};
    }
    std::string text(int c) const {
      const auto* p = sqlite3_column_text(s_, c);
      return p ? std::string(reinterpret_cast<const char*>(p),
                             static_cast<std::size_t>(sqlite3_column_bytes(s_, c)))
               : std::string();
    }

  private:
    sqlite3_stmt* s_;
  };

private:
  sqlite3* db_ = nullptr;
  StmtPtr stmt_;
  int rc_ = SQLITE_MISUSE;
};

/** Runs SQL without results; returns the SQLite code. */
inline int exec(sqlite3* db, const char* sqlText) {
  return sqlite3_exec(db, sqlText, nullptr, nullptr, nullptr);
}

} // namespace tellus::sql
