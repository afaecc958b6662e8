// What the front ends share (FrontEnd.hpp): their state, and the one way a tile, a plain-text
// error, a temporary failure and a client's view of a message are made.
#include "frontend/FrontEnd.hpp"

#include <tellus/proxy/Query.hpp>

#include <algorithm>
#include <cctype>
#include <ctime>

namespace tellus {

namespace {

std::vector<std::string> layerNames(const TileService& t) {
  std::vector<std::string> names;
  for (const auto& l : t.layers())
    names.push_back(l.name);
  return names;
}

TileOutcome outcomeOf(const TileAnswer& a) {
  if (a.kind == TileAnswer::Kind::Error) {
    if (a.failure == TileAnswer::Failure::OverBudget) return TileOutcome::Refused;
    return a.origin == TileOrigin::Offline ? TileOutcome::Offline : TileOutcome::Error;
  }
  if (a.kind == TileAnswer::Kind::Absent)
    return a.origin == TileOrigin::Offline ? TileOutcome::Offline : TileOutcome::Absent;
  switch (a.origin) {
  case TileOrigin::Hit:
    return TileOutcome::Hit;
  case TileOrigin::Miss:
    return TileOutcome::Miss;
  case TileOrigin::Stale:
    return TileOutcome::Stale;
  case TileOrigin::Offline:
    return TileOutcome::Offline;
  }
  return TileOutcome::Error;
}

bool safeHost(std::string_view h) {
  return !h.empty() && h.size() < 256 && std::all_of(h.begin(), h.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == ':' ||
           c == '[' || c == ']';
  });
}

} // namespace

FrontEnd::FrontEnd(TileService& t, FrontEndOptions o)
    : tiles(t), options(std::move(o)), metrics(layerNames(t)), startedMillis(unixMillisNow()),
      budget(options.fetchesPerClientPerMinute, options.clock ? *options.clock : Clock::system()),
      composer(t,
               options.composeThreads,
               options.maxTilesPerMap,
               options.decodedTileCacheBytes,
               options.jpegQuality) {
  const auto now = unixMillisNow();
  updateSequence =
      options.updateSequence.empty() ? std::to_string(now / 1000) : options.updateSequence;
  // The service's LastUpdate: the newest of its layers' (see capabilitiesModel).
  UnixMillis newest = 0;
  for (const auto& l : tiles.layers())
    newest = std::max(newest, tiles.layerSince(l.name));
  const std::time_t secs = static_cast<std::time_t>((newest > 0 ? newest : now) / 1000);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  lastUpdate = buf;
}

void FrontEnd::countTile(const LayerSpec* l, const TileAnswer& a) {
  metrics.tile(static_cast<std::size_t>(l - tiles.layers().data()), outcomeOf(a));
}

void FrontEnd::common(HttpResponse& r) const {
  if (!options.cors.empty()) r.setHeader("Access-Control-Allow-Origin", options.cors);
}

HttpResponse FrontEnd::plain(int status, std::string_view text) const {
  auto r = HttpResponse::text(status, "text/plain; charset=utf-8", text);
  common(r);
  return r;
}

// ---- errors -------------------------------------------------------------------------------------

std::string FrontEnd::clientMessage(std::string_view message) {
  // Cut first as well: a message is at most kMaxClientMessageBytes once it is redacted.
  std::string m = sanitizeForClient(message.substr(0, 8 * kMaxClientMessageBytes));
  if (m.size() > kMaxClientMessageBytes) {
    std::size_t cut = kMaxClientMessageBytes;
    while (cut > 0 && (static_cast<unsigned char>(m[cut]) & 0xC0u) == 0x80u)
      --cut;
    m.resize(cut);
    m += "...";
  }
  return m;
}

HttpResponse FrontEnd::errorText(int status, std::string_view message) const {
  return plain(status, clientMessage(message) + "\n");
}

std::optional<FrontEnd::Temporary> FrontEnd::temporary(TileAnswer::Failure f,
                                                       std::int64_t retryAfter) {
  if (f == TileAnswer::Failure::Bad) return std::nullopt;
  return Temporary{f == TileAnswer::Failure::OverBudget ? 429 : 503,
                   std::max<std::int64_t>(1, retryAfter)};
}

void FrontEnd::markTemporary(HttpResponse& r, const Temporary& t) {
  r.status = t.status;
  r.setHeader("Retry-After", std::to_string(t.retryAfterSeconds));
  r.setHeader("Cache-Control", "no-store");
}

// ---- the request --------------------------------------------------------------------------------

FetchGate FrontEnd::gateFor(const HttpRequest& req) {
  return FetchGate{budget.unlimited() ? nullptr : &budget, req.remoteAddress};
}

std::string FrontEnd::baseUrl(const HttpRequest& req) const {
  if (!options.publicUrl.empty()) {
    std::string u = options.publicUrl;
    while (!u.empty() && u.back() == '/')
      u.pop_back();
    return u;
  }
  std::string_view proto = req.header("x-forwarded-proto");
  if (proto != "https") proto = "http";
  std::string_view host = req.header("x-forwarded-host");
  if (const auto comma = host.find(','); comma != std::string_view::npos)
    host = host.substr(0, comma);
  if (!safeHost(host)) host = req.header("host");
  if (!safeHost(host)) host = "localhost";
  std::string prefix(req.header("x-forwarded-prefix"));
  const bool prefixOk = std::all_of(prefix.begin(), prefix.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '/' || c == '-' || c == '_' ||
           c == '.';
  });
  if (!prefixOk || (!prefix.empty() && prefix.front() != '/')) prefix.clear();
  while (!prefix.empty() && prefix.back() == '/')
    prefix.pop_back();
  return std::string(proto) + "://" + std::string(host) + prefix;
}

std::expected<std::string, OgcException> FrontEnd::resolveTime(const LayerSpec& l,
                                                               std::string_view t) {
  return resolveTimeDimension(l.name, l.timeValues, l.timePeriod, l.timeDefault, t);
}

// ---- a tile as cached ---------------------------------------------------------------------------

void FrontEnd::cacheHeaders(HttpResponse& r,
                            std::chrono::seconds maxAge,
                            std::chrono::milliseconds ttl,
                            bool stale,
                            const std::string& keys) const {
  r.setHeader("Cache-Control",
              stale ? shortCacheControl(options.cdn) : tileCacheControl(maxAge, ttl, options.cdn));
  if (!options.cdn.keyHeader.empty() && !keys.empty()) r.setHeader(options.cdn.keyHeader, keys);
}

void FrontEnd::shortLived(HttpResponse& r, const std::string& keys) const {
  r.setHeader("Cache-Control", shortCacheControl(options.cdn));
  if (!options.cdn.keyHeader.empty() && !keys.empty()) r.setHeader(options.cdn.keyHeader, keys);
}

void FrontEnd::finishCaching(HttpResponse& r) const {
  std::string_view cc;
  for (const auto& [k, v] : r.headers)
    if (k == "Cache-Control") cc = v;
  if (keepable(r.status, cc)) return;
  r.setHeader("Cache-Control", std::string(kNoStore));
  const std::string& key = options.cdn.keyHeader;
  if (!key.empty()) std::erase_if(r.headers, [&](const auto& h) { return h.first == key; });
}

void FrontEnd::sendTile(const Validators& req,
                        TileAnswer&& a,
                        const LayerSpec& l,
                        const std::string& keys,
                        const Responder& respond,
                        bool provisional) const {
  HttpResponse r;
  r.headers.reserve(8);
  common(r);
  r.setHeader("ETag", a.etag);
  r.setHeader("Last-Modified", formatHttpDate(a.fetchedAt));
  cacheHeaders(r, l.maxAge, l.ttl, provisional || a.origin == TileOrigin::Stale, keys);
  r.setHeader("X-Cache", toString(a.origin));
  const std::string_view inm = req.ifNoneMatch;
  bool notModified = false;
  if (!inm.empty()) {
    notModified = ifNoneMatchHits(inm, a.etag);
  } else if (const auto ims = parseHttpDate(req.ifModifiedSince)) {
    notModified = a.fetchedAt / 1000 <= *ims / 1000; // HTTP dates have whole seconds
  }
  if (notModified) {
    r.status = 304;
  } else {
    r.status = 200;
    r.setHeader("Content-Type", a.contentType);
    if (a.file) {
      const auto size = a.file->size();
      const int fd = a.file->fd();
      r.file = HttpFileBody{fd, size, std::move(a.file)};
    } else {
      r.body = std::move(a.bytes);
    }
  }
  respond(std::move(r));
}

} // namespace tellus
