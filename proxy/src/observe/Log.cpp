#include <tellus/proxy/Log.hpp>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <ctime>

namespace tellus {

const char* toString(LogLevel level) noexcept {
  switch (level) {
  case LogLevel::Error:
    return "error";
  case LogLevel::Warn:
    return "warn";
  case LogLevel::Info:
    return "info";
  case LogLevel::Debug:
    return "debug";
  }
  return "info";
}

std::optional<LogLevel> parseLogLevel(std::string_view text) noexcept {
  for (const LogLevel l : {LogLevel::Error, LogLevel::Warn, LogLevel::Info, LogLevel::Debug}) {
    if (text == toString(l)) return l;
  }
  return std::nullopt;
}

std::string logfmtValue(std::string_view value) {
  bool bare = !value.empty();
  for (const char c : value) {
    const auto u = static_cast<unsigned char>(c);
    if (c == ' ' || c == '"' || c == '=' || c == '\\' || u < 0x20 || u == 0x7f) {
      bare = false;
      break;
    }
  }
  if (bare) return std::string(value);
  std::string out = "\"";
  for (const char c : value) {
    const auto u = static_cast<unsigned char>(c);
    switch (c) {
    case '"':
      out += "\\\"";
      break;
    case '\\':
      out += "\\\\";
      break;
    case '\n':
      out += "\\n";
      break;
    case '\r':
      out += "\\r";
      break;
    case '\t':
      out += "\\t";
      break;
    default:
      if (u < 0x20 || u == 0x7f) {
        char buf[8];
        std::snprintf(buf, sizeof buf, "\\x%02x", u);
        out += buf;
      } else {
        out += c;
      }
    }
  }
  out += '"';
  return out;
}

namespace {

std::string timestamp() {
  const auto now = std::chrono::system_clock::now();
  const auto ms =
      std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count();
  const std::time_t secs = static_cast<std::time_t>(ms / 1000);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char buf[40];
  const std::size_t n = std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
  std::snprintf(buf + n, sizeof buf - n, ".%03dZ", static_cast<int>(ms % 1000));
  return buf;
}

void appendFields(std::string& line, std::initializer_list<LogField> fields) {
  for (const auto& [k, v] : fields) {
    line += ' ';
    line += k;
    line += '=';
    line += logfmtValue(v);
  }
}

} // namespace

Logger::~Logger() {
  if (ownsAccess_ && access_.load()) std::fclose(access_.load());
}

void Logger::setEventStream(std::FILE* stream) noexcept {
  std::lock_guard lock(mutex_);
  events_ = stream;
}

bool Logger::openAccessLog(const std::string& where, std::string* error) {
  std::lock_guard lock(mutex_);
  std::FILE* old = access_.exchange(nullptr);
  if (ownsAccess_ && old) std::fclose(old);
  ownsAccess_ = false;
  if (where.empty()) return true;
  if (where == "-") {
    access_.store(stdout, std::memory_order_release);
    return true;
  }
  std::FILE* f = std::fopen(where.c_str(), "ae");
  if (!f) {
    if (error) *error = "cannot open the access log " + where + ": " + std::strerror(errno);
    return false;
  }
  ownsAccess_ = true;
  access_.store(f, std::memory_order_release);
  return true;
}

void Logger::write(std::FILE* stream, const std::string& line) {
  // One fwrite per line; flushed so that a line is never held back (tail -f, crashes).
  std::fwrite(line.data(), 1, line.size(), stream);
  std::fflush(stream);
}

void Logger::log(LogLevel level,
                 std::string_view component,
                 std::string_view message,
                 std::initializer_list<LogField> fields) {
  if (!enabled(level)) return;
  std::string line = "time=" + timestamp() + " level=" + toString(level) +
                     " component=" + logfmtValue(component) + " msg=" + logfmtValue(message);
  appendFields(line, fields);
  line += '\n';
  std::lock_guard lock(mutex_);
  if (events_) write(events_, line);
}

void Logger::access(std::initializer_list<LogField> fields) {
  if (!accessLogEnabled()) return;
  std::string line = "time=" + timestamp();
  appendFields(line, fields);
  line += '\n';
  std::lock_guard lock(mutex_);
  if (std::FILE* f = access_.load()) write(f, line);
}

Logger& logger() {
  static Logger instance;
  return instance;
}

} // namespace tellus
