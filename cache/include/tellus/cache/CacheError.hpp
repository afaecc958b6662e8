#pragma once
/** @file CacheError.hpp @brief The error value of every fallible cache operation. */

#include <string>

namespace tellus {

/** What went wrong, independent of any protocol (the proxy maps it to HTTP in one place). */
enum class CacheErrc {
  InvalidArgument, ///< bad key (level/row/col outside the grid), unknown dataset, bad name
  Io,              ///< a file or SQLite operation failed (message says which)
  DiskFull,        ///< ENOSPC / EFBIG / SQLITE_FULL: nothing was written, the index is unchanged
  Corrupt,         ///< the index is damaged; it is moved aside and rebuilt at the next open
  Schema,          ///< the index was written by a newer tellus (user_version too high)
  ReadOnly,        ///< a write on a cache opened read-only
};

struct CacheError {
  CacheErrc code = CacheErrc::Io;
  std::string message;
};

/** Short name of an error code ("disk full", ...). */
const char* toString(CacheErrc code) noexcept;

} // namespace tellus
