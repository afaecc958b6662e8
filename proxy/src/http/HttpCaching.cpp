// Cache-Control and surrogate keys for shared caches (HttpCaching.hpp, docs/design/cdn.md).
#include <tellus/proxy/HttpCaching.hpp>

#include <algorithm>

namespace tellus {

namespace {

constexpr std::int64_t kDay = 86400;

std::string keySafe(std::string_view s) {
  std::string out(s);
  for (char& c : out)
    if (c == ' ' || c == ',' || c == '\t' || static_cast<unsigned char>(c) < 0x20) c = '_';
  return out;
}

} // namespace

std::string tileCacheControl(std::chrono::seconds maxAge,
                             std::chrono::milliseconds ttl,
                             const CdnOptions& cdn) {
  const std::int64_t browser = std::max<std::int64_t>(0, maxAge.count());
  const std::int64_t ttlSeconds = std::chrono::duration_cast<std::chrono::seconds>(ttl).count();
  const std::int64_t shared =
      cdn.sMaxAge ? cdn.sMaxAge->count()
                  : (ttl.count() > 0 ? std::max<std::int64_t>(1, ttlSeconds) : browser);
  const std::int64_t swr = cdn.staleWhileRevalidate ? cdn.staleWhileRevalidate->count()
                                                    : std::min<std::int64_t>(shared, kDay);
  std::string v =
      "public, max-age=" + std::to_string(browser) + ", s-maxage=" + std::to_string(shared);
  if (swr > 0) v += ", stale-while-revalidate=" + std::to_string(swr);
  if (cdn.staleIfError.count() > 0)
    v += ", stale-if-error=" + std::to_string(cdn.staleIfError.count());
  return v;
}

std::string shortCacheControl(const CdnOptions& cdn) {
  const std::string s = std::to_string(cdn.shortMaxAge.count());
  return "public, max-age=" + s + ", s-maxage=" + s;
}

bool keepable(int status, std::string_view cacheControl) {
  if (status < 400) return true;
  return status == 404 && cacheControl.starts_with("public");
}

std::string layerKey(std::string_view layer, std::string_view time) {
  std::string k = "layer:" + keySafe(layer);
  if (!time.empty()) k += "@" + keySafe(time);
  return k;
}

std::string layerKeys(std::string_view layer, std::string_view time, std::int32_t level) {
  std::string k = "tellus " + layerKey(layer);
  if (!time.empty()) k += " " + layerKey(layer, time);
  if (level >= 0) k += " " + layerKey(layer) + "/" + std::to_string(level);
  return k;
}

std::string capabilitiesKeys() {
  return "tellus capabilities";
}

} // namespace tellus
