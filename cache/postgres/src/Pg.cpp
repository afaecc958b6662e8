#include "Pg.hpp"

#include <charconv>
#include <fstream>
#include <system_error>

namespace tellus {

bool isPostgresUri(std::string_view text) {
  return text.starts_with("postgresql://") || text.starts_with("postgres://");
}

std::string redactConninfo(std::string_view conninfo) {
  std::string out(conninfo);
  if (isPostgresUri(out)) {
    const std::size_t start = out.find("://") + 3;
    const std::size_t end = out.find_first_of("/?", start);
    const std::size_t at = out.rfind('@', end == std::string::npos ? out.size() : end);
    if (at != std::string::npos && at > start) {
      const std::size_t colon = out.find(':', start);
      if (colon != std::string::npos && colon < at) out.replace(colon + 1, at - colon - 1, "***");
    }
  }
  // `password=...` as a URI parameter (up to & or the end) or a key=value pair (up to a space).
  for (std::size_t p = out.find("password="); p != std::string::npos;
       p = out.find("password=", p + 1)) {
    const std::size_t from = p + 9;
    std::size_t to = out.find_first_of("& ", from);
    if (to == std::string::npos) to = out.size();
    out.replace(from, to - from, "***");
  }
  return out;
}

std::expected<void, CacheError> checkConninfo(std::string_view conninfo) {
  char* err = nullptr;
  const std::string text(conninfo);
  PQconninfoOption* opts = PQconninfoParse(text.c_str(), &err);
  if (!opts) {
    std::string msg = err ? err : "out of memory";
    PQfreemem(err);
    while (!msg.empty() && (msg.back() == '\n' || msg.back() == ' '))
      msg.pop_back();
    // libpq's parse errors quote no value of the string: they are safe to show.
    return std::unexpected(
        CacheError{CacheErrc::InvalidArgument, "not a PostgreSQL connection string (" + msg + ")"});
  }
  bool hasPassword = false;
  for (const PQconninfoOption* o = opts; o->keyword; ++o) {
    if (std::string_view(o->keyword) == "password" && o->val && *o->val) hasPassword = true;
  }
  PQconninfoFree(opts);
  if (hasPassword) {
    return std::unexpected(CacheError{
        CacheErrc::InvalidArgument,
        "the PostgreSQL connection string " + redactConninfo(conninfo) +
            " holds a password; give it in PGPASSWORD, a PGPASSFILE, or a password file"});
  }
  return {};
}

namespace pg {

Params& Params::add(std::int64_t v) {
  values_.emplace_back(std::to_string(v));
  return *this;
}

Params& Params::add(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  values_.emplace_back(std::string(buf, r.ptr));
  return *this;
}

Params& Params::add(std::string_view v) {
  values_.emplace_back(std::string(v));
  return *this;
}

Params& Params::add(const std::optional<std::int64_t>& v) {
  return v ? add(*v) : addNull();
}

Params& Params::addNull() {
  values_.emplace_back(std::nullopt);
  return *this;
}

std::vector<const char*> Params::pointers() const {
  std::vector<const char*> out;
  out.reserve(values_.size());
  for (const auto& v : values_)
    out.push_back(v ? v->c_str() : nullptr);
  return out;
}

namespace {

std::string trimmed(const char* s) {
  std::string m = s ? s : "";
  while (!m.empty() && (m.back() == '\n' || m.back() == ' '))
    m.pop_back();
  return m;
}

} // namespace

std::expected<ConnPtr, CacheError> connect(const PgConnectOptions& options) {
  if (auto ok = checkConninfo(options.conninfo); !ok) return std::unexpected(ok.error());
  std::string password;
  if (options.passwordFile) {
    std::ifstream in(*options.passwordFile);
    if (!in || !std::getline(in, password)) {
      return std::unexpected(
          CacheError{CacheErrc::Io,
                     "cannot read the PostgreSQL password file " + options.passwordFile->string()});
    }
    if (!password.empty() && password.back() == '\r') password.pop_back();
  }
  const std::string timeout = std::to_string(options.connectTimeout.count());
  std::vector<const char*> keys{"dbname", "connect_timeout", "fallback_application_name"};
  std::vector<const char*> values{options.conninfo.c_str(), timeout.c_str(), "tellus"};
  if (options.passwordFile) {
    keys.push_back("password");
    values.push_back(password.c_str());
  }
  keys.push_back(nullptr);
  values.push_back(nullptr);
  ConnPtr conn(PQconnectdbParams(keys.data(), values.data(), 1));
  if (!conn) return std::unexpected(CacheError{CacheErrc::Io, "out of memory connecting"});
  if (PQstatus(conn.get()) != CONNECTION_OK) {
    return std::unexpected(CacheError{CacheErrc::Io,
                                      "cannot connect to PostgreSQL at " +
                                          redactConninfo(options.conninfo) + ": " +
                                          trimmed(PQerrorMessage(conn.get()))});
  }
  return conn;
}

CacheError errorFrom(PGconn* conn, const PGresult* result, std::string_view what) {
  const char* state = result ? PQresultErrorField(result, PG_DIAG_SQLSTATE) : nullptr;
  CacheErrc code = CacheErrc::Io;
  if (state && std::string_view(state) == "53100") code = CacheErrc::DiskFull;
  if (state && std::string_view(state) == "XX001") code = CacheErrc::Corrupt;
  const std::string message = trimmed(result ? PQresultErrorMessage(result) : PQerrorMessage(conn));
  return CacheError{code,
                    "PostgreSQL: " + std::string(what) + ": " +
                        (message.empty() ? std::string("the connection is gone") : message)};
}

bool broken(PGconn* conn) noexcept {
  return conn == nullptr || PQstatus(conn) != CONNECTION_OK;
}

std::expected<ResultPtr, CacheError>
exec(PGconn* conn, const char* sql, const Params& params, const char* what) {
  const auto ptrs = params.pointers();
  ResultPtr r(PQexecParams(conn, sql, params.size(), nullptr, ptrs.data(), nullptr, nullptr, 0));
  const ExecStatusType st = r ? PQresultStatus(r.get()) : PGRES_FATAL_ERROR;
  if (st != PGRES_COMMAND_OK && st != PGRES_TUPLES_OK)
    return std::unexpected(errorFrom(conn, r.get(), what));
  return r;
}

std::expected<ResultPtr, CacheError> exec(PGconn* conn, const char* sql, const char* what) {
  ResultPtr r(PQexec(conn, sql)); // simple protocol: may hold several statements
  const ExecStatusType st = r ? PQresultStatus(r.get()) : PGRES_FATAL_ERROR;
  if (st != PGRES_COMMAND_OK && st != PGRES_TUPLES_OK)
    return std::unexpected(errorFrom(conn, r.get(), what));
  return r;
}

std::int64_t i64(const PGresult* r, int row, int col) {
  const char* s = PQgetvalue(r, row, col);
  std::int64_t v = 0;
  std::from_chars(s, s + PQgetlength(r, row, col), v);
  return v;
}

double f64(const PGresult* r, int row, int col) {
  const char* s = PQgetvalue(r, row, col);
  double v = 0;
  std::from_chars(s, s + PQgetlength(r, row, col), v);
  return v;
}

std::string text(const PGresult* r, int row, int col) {
  return std::string(PQgetvalue(r, row, col), static_cast<std::size_t>(PQgetlength(r, row, col)));
}

bool isNull(const PGresult* r, int row, int col) {
  return PQgetisnull(r, row, col) != 0;
}

std::optional<std::int64_t> optI64(const PGresult* r, int row, int col) {
  if (isNull(r, row, col)) return std::nullopt;
  return i64(r, row, col);
}

} // namespace pg
} // namespace tellus
