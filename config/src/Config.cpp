#include <tellus/config/Config.hpp>

#include <cstdlib>
#include <system_error>

namespace tellus {

const LayerConfig* Config::layer(std::string_view name) const noexcept {
  for (const auto& l : layers) {
    if (l.name == name) return &l;
  }
  return nullptr;
}

const UpstreamConfig* Config::upstream(std::string_view name) const noexcept {
  for (const auto& u : upstreams) {
    if (u.name == name) return &u;
  }
  return nullptr;
}

const BodyConfig* Config::body(std::string_view name) const noexcept {
  for (const auto& b : bodies) {
    if (b.name == name) return &b;
  }
  return nullptr;
}

bool Config::knowsBody(std::string_view name) const noexcept {
  for (const std::string_view b : kBuiltinBodies)
    if (b == name) return true;
  return body(name) != nullptr;
}

std::string ConfigError::toString() const {
  std::string s = file.empty() ? std::string("<config>") : file;
  if (line > 0) {
    s += ":" + std::to_string(line);
    if (column > 0) s += ":" + std::to_string(column);
  }
  s += ": ";
  if (!key.empty()) s += key + ": ";
  return s + message;
}

std::filesystem::path defaultCacheRoot() {
  if (const char* t = std::getenv("TELLUS_CACHE"); t && *t) return t;
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x)
    return std::filesystem::path(x) / "tellus";
  if (const char* h = std::getenv("HOME"); h && *h)
    return std::filesystem::path(h) / ".cache" / "tellus";
  std::error_code ec;
  const std::filesystem::path cwd = std::filesystem::current_path(ec);
  return (ec ? std::filesystem::path(".") : cwd) / "tellus-cache";
}

} // namespace tellus

namespace tellus {

std::optional<std::string> checkIndexUri(std::string_view uri) {
  if (uri.empty()) return std::nullopt;
  if (!uri.starts_with("postgresql://") && !uri.starts_with("postgres://")) {
    return "cache.index takes a postgresql:// URI (or nothing: SQLite in cache.root)";
  }
  const std::size_t start = uri.find("://") + 3;
  const std::size_t hostEnd = uri.find_first_of("/?", start);
  const std::string_view authority = uri.substr(start, hostEnd - start);
  const std::size_t at = authority.rfind('@');
  const bool userPassword =
      at != std::string_view::npos && authority.substr(0, at).find(':') != std::string_view::npos;
  const std::size_t q = uri.find('?');
  const bool passwordParam =
      q != std::string_view::npos && (uri.find("?password=", q) != std::string_view::npos ||
                                      uri.find("&password=", q) != std::string_view::npos);
  if (userPassword || passwordParam) {
    return "cache.index holds a password; give it in PGPASSWORD, a PGPASSFILE, or "
           "cache.index_password_file (a file whose first line is the password)";
  }
  return std::nullopt;
}

} // namespace tellus
