#pragma once
/**
 * @file ProxyFrontEnd.hpp
 * @brief The protocol front end of `tellus serve`: routes HTTP requests to WMS (GetCapabilities,
 * tile-aligned GetMap), World Wind tiles (`/wwtile?T=&L=&X=&Y=`) and the static World Wind layout
 * (`/tiles/<layer>/<level>/<row>/<row>_<col>.<ext>`), and is the one place where HTTP status codes,
 * caching headers and OGC exception bodies are made.
 */

#include <tellus/proxy/FetchBudget.hpp>
#include <tellus/proxy/HttpCaching.hpp>
#include <tellus/proxy/HttpDates.hpp> // formatHttpDate, parseHttpDate, ifNoneMatchHits
#include <tellus/proxy/HttpServer.hpp>
#include <tellus/proxy/TileService.hpp>
#include <tellus/proxy/Wms.hpp>

#include <cstdint>
#include <memory>
#include <string>

namespace tellus {

struct FrontEndOptions {
  std::string title = "tellus tile cache";
  std::string publicUrl;             ///< base URL for capabilities; "" = from Host / X-Forwarded-*
  std::string cors = "*";            ///< Access-Control-Allow-Origin; "" = none
  bool exceptionsHttpStatus = false; ///< WMS exceptions with 4xx/5xx instead of 200
  enum class OfflineResponse { Exception, Blank } offlineResponse = OfflineResponse::Exception;
  WmsLimits limits;
  /** GetMap for a box that is not one tile is composed from tiles: at most this many pixels
   * (WIDTH x HEIGHT) and this many tiles per map (all layers), else InvalidParameterValue. */
  std::int64_t maxMapPixels = 4096LL * 4096LL;
  std::size_t maxTilesPerMap = 256;
  int composeThreads = 2; ///< workers that decode, sample and encode composed maps
  /** Decoded tiles kept between composed maps (whole tiles, by ETag, least recently used out, a
   * tile admitted when used often enough); 0: none, and only the sampled part of each JPEG tile
   * is decoded. The configuration's default. */
  std::size_t decodedTileCacheBytes = 32u << 20;
  int jpegQuality = 90; ///< of composed JPEG maps, 1-100
  std::size_t maxParamBytes = 2048;
  std::size_t maxQueryBytes = 16384;
  std::string updateSequence; ///< capabilities UpdateSequence ("" = derived from the start time)
  /** Upstream fetches one client address may cause per minute (FetchBudget: a minute's worth at
   * once, refilled evenly); past it a request that needs a fetch gets 429 with Retry-After (an OGC
   * exception with status 429 for /wms) while cached tiles stay served. 0 = unlimited. */
  double fetchesPerClientPerMinute = 600;
  /// The fetch budget's time; null: the system's (tests inject a ManualClock, which outlives the
  /// front end).
  const Clock* clock = nullptr;
  /// What shared caches (a CDN, Varnish) are told: s-maxage, stale-*, surrogate keys
  /// (HttpCaching.hpp, docs/design/cdn.md).
  CdnOptions cdn;
};

class ProxyFrontEnd {
public:
  ProxyFrontEnd(TileService& tiles, FrontEndOptions options);
  ~ProxyFrontEnd();

  /** The HttpHandler: never throws, answers exactly once. Refused requests
   * (HttpRequest::refusal) are answered here too, counted and logged like any other. */
  void handle(HttpRequest&& request, Responder respond);

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

} // namespace tellus
