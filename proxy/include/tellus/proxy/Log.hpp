#pragma once
/**
 * @file Log.hpp
 * @brief Structured logs of `tellus serve`: one logfmt line per event (`time=... level=warn
 * component=tiles msg="..." key=value ...`), filtered by level, and an access log with one line per
 * answered request. Lines are written whole (one fwrite under a lock), so concurrent threads never
 * interleave within a line.
 */

#include <atomic>
#include <cstdio>
#include <initializer_list>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

namespace tellus {

enum class LogLevel { Error = 0, Warn = 1, Info = 2, Debug = 3 };
const char* toString(LogLevel level) noexcept;
/** "error", "warn", "info" or "debug". */
std::optional<LogLevel> parseLogLevel(std::string_view text) noexcept;

/** A logfmt value: bare when it has no space, quote, '=' or control character, else quoted with
 * `\"`, `\\`, `\n`, `\r`, `\t` escaped (other control bytes as \xNN). */
std::string logfmtValue(std::string_view value);

using LogField = std::pair<std::string_view, std::string_view>;

class Logger {
public:
  /** Events to stderr at Info; no access log. */
  Logger() = default;
  ~Logger();
  Logger(const Logger&) = delete;
  Logger& operator=(const Logger&) = delete;

  void setLevel(LogLevel level) noexcept { level_.store(level, std::memory_order_relaxed); }
  LogLevel level() const noexcept { return level_.load(std::memory_order_relaxed); }
  bool enabled(LogLevel level) const noexcept { return level <= this->level(); }
  /** Where events go (not owned; default stderr). */
  void setEventStream(std::FILE* stream) noexcept;
  /** Opens the access log: "-" is stdout, anything else a file appended to; "" turns it off. */
  bool openAccessLog(const std::string& where, std::string* error);
  bool accessLogEnabled() const noexcept {
    return access_.load(std::memory_order_acquire) != nullptr;
  }

  void log(LogLevel level,
           std::string_view component,
           std::string_view message,
           std::initializer_list<LogField> fields = {});
  /** One access-log line with these fields (time first). */
  void access(std::initializer_list<LogField> fields);

private:
  void write(std::FILE* stream, const std::string& line);
  std::atomic<LogLevel> level_{LogLevel::Info};
  std::FILE* events_ = stderr; // under mutex_
  std::atomic<std::FILE*> access_{nullptr};
  bool ownsAccess_ = false;
  std::mutex mutex_;
};

/** The process's logger. */
Logger& logger();

} // namespace tellus
