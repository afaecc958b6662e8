#pragma once
/**
 * @file ProxyFromConfig.hpp
 * @brief The configuration in the proxy's terms: the adapter between two modules that do not know
 * each other. The proxy takes plain option structs (so that tests and other front ends drive it
 * without YAML) and config knows nothing of the proxy; `tellus serve`, `seed`, `render`, `view`
 * and `height` map one onto the other here, field by field, and nowhere else.
 */

#include <tellus/config/Config.hpp>
#include <tellus/proxy/HttpServer.hpp>
#include <tellus/proxy/ProxyFrontEnd.hpp>
#include <tellus/proxy/TileService.hpp>

#include <vector>

namespace tellus::cli {

/** An upstream of YAML `upstreams` as the tile service fetches from it: its type, address and
 * fetch policy (timeouts, retries, circuit breaker, Retry-After, headers, redirects). */
UpstreamSpec upstreamSpec(const UpstreamConfig& upstream);

/** A layer of YAML `layers` as the proxy serves it. An elevation layer's no-data value is clamped
 * into the 16-bit range of its tiles. */
LayerSpec layerSpec(const LayerConfig& layer);

/** Every upstream and every layer of a configuration, in its order. */
struct ProxySpecs {
  std::vector<UpstreamSpec> upstreams;
  std::vector<LayerSpec> layers;
};
ProxySpecs proxySpecs(const Config& config);

/** The tile service of YAML `server`: offline when it says so. */
TileServiceOptions tileServiceOptions(const ServerSettings& server);

/** The WMS / World Wind front end of YAML `server` (public URL, CORS, exceptions, limits, JPEG
 * quality), composing maps on `composeThreads` workers (at least 1). */
FrontEndOptions frontEndOptions(const ServerSettings& server, int composeThreads);

/** What shared caches are told, and where purges go (YAML `server.cdn`). */
CdnOptions cdnOptions(const CdnSettings& cdn);

/** The HTTP server of YAML `server`: where it listens, its threads and its limits (at least one
 * connection). */
HttpServerOptions httpServerOptions(const ServerSettings& server);

} // namespace tellus::cli
