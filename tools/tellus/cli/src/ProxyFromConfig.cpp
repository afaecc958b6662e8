#include <tellus/cli/ProxyFromConfig.hpp>

#include <algorithm>
#include <cstddef>
#include <cstdint>

namespace tellus::cli {
namespace {

UpstreamSpec::Type upstreamType(UpstreamConfig::Type t) {
  switch (t) {
  case UpstreamConfig::Type::Local:
    return UpstreamSpec::Type::Local;
  case UpstreamConfig::Type::Wms:
    return UpstreamSpec::Type::Wms;
  case UpstreamConfig::Type::WorldWind:
    return UpstreamSpec::Type::WorldWind;
  case UpstreamConfig::Type::Wmts:
    return UpstreamSpec::Type::Wmts;
  }
  return UpstreamSpec::Type::WorldWind;
}

UpstreamPolicy::Redirects redirects(RedirectPolicy r) {
  switch (r) {
  case RedirectPolicy::Any:
    return UpstreamPolicy::Redirects::Any;
  case RedirectPolicy::None:
    return UpstreamPolicy::Redirects::None;
  case RedirectPolicy::SameOrigin:
    return UpstreamPolicy::Redirects::SameOrigin;
  }
  return UpstreamPolicy::Redirects::SameOrigin;
}

} // namespace

UpstreamSpec upstreamSpec(const UpstreamConfig& u) {
  UpstreamSpec s;
  s.name = u.name;
  s.type = upstreamType(u.type);
  s.path = u.path;
  s.url = u.url;
  s.wmsVersion = u.wmsVersion;
  s.crs = u.crs;
  s.metaTiles = u.metaTiles;
  s.wmtsEncoding = u.encoding == UpstreamConfig::Encoding::Rest  ? WmtsEncoding::Rest
                   : u.encoding == UpstreamConfig::Encoding::Kvp ? WmtsEncoding::Kvp
                                                                 : WmtsEncoding::Auto;
  s.policy.maxConnections = u.maxConnections;
  s.policy.connectTimeout = u.connectTimeout;
  s.policy.timeout = u.timeout;
  s.policy.retries = u.retries;
  s.policy.retryBackoff = u.retryBackoff;
  s.policy.failureThreshold = u.failureThreshold;
  s.policy.openInterval = u.openInterval;
  s.policy.maxRetryAfterWait = u.maxRetryAfterWait;
  s.policy.headers = u.headers;
  s.policy.redirects = redirects(u.redirects);
  return s;
}

namespace {

/** A value or elevation layer's values (ValueLayer.hpp): a value layer's default style is its
 * colour map; an elevation layer's stays as before (heights, or the grey ramp), its colour maps
 * offered by name. */
ValueLayerSpec valueLayerSpec(const LayerConfig& l) {
  const ValueSettings& v = l.values;
  ValueLayerSpec s;
  s.format = v.format;
  s.defaultStyle = l.kind == LayerKind::Values ? v.colourMap : std::string();
  if (v.styles.empty()) {
    for (const values::ColourMap& m : values::colourMaps())
      s.styles.emplace_back(m.name);
  } else {
    s.styles = v.styles;
  }
  s.rangeFromData = v.rangeFromData;
  s.min = v.min;
  s.max = v.max;
  s.lowPercent = v.lowPercent;
  s.highPercent = v.highPercent;
  s.scaling = v.scaling;
  s.outOfRange = v.outOfRange;
  return s;
}

} // namespace

LayerSpec layerSpec(const LayerConfig& l) {
  LayerSpec s;
  s.name = l.name;
  s.title = l.title;
  s.abstract = l.abstract;
  s.dataset = l.dataset;
  s.upstream = l.upstream;
  s.upstreamLayer = l.upstreamLayer;
  s.tileMatrixSet = l.tileMatrixSet;
  s.firstLevel = l.firstLevel;
  s.elevation = l.kind == LayerKind::Elevation;
  // The no-data sample of tiles a local raster renders (and of heights maps): a value layer's
  // own `values.no_data` when it has one, so that the tiles mean what the layer says they mean.
  const double noData = l.kind == LayerKind::Values && l.values.format.noData
                            ? *l.values.format.noData
                            : l.elevation.noData;
  s.noData = static_cast<std::int16_t>(std::clamp(noData, -32768.0, 32767.0));
  s.ttl = l.ttl;
  s.opacity = l.opacity;
  s.maxAge = l.maxAge;
  s.timeValues = l.time.values;
  s.timePeriod = l.time.period;
  s.timeDefault = l.time.defaultValue;
  if (l.isValueLayer()) s.values = valueLayerSpec(l);
  return s;
}

ProxySpecs proxySpecs(const Config& c) {
  ProxySpecs out;
  for (const UpstreamConfig& u : c.upstreams)
    out.upstreams.push_back(upstreamSpec(u));
  for (const LayerConfig& l : c.layers)
    out.layers.push_back(layerSpec(l));
  return out;
}

TileServiceOptions tileServiceOptions(const ServerSettings& server) {
  TileServiceOptions o;
  o.offline = server.offline;
  return o;
}

FrontEndOptions frontEndOptions(const ServerSettings& server, int composeThreads) {
  FrontEndOptions o;
  o.publicUrl = server.publicUrl;
  o.cors = server.cors;
  o.exceptionsHttpStatus = server.exceptionsHttpStatus;
  o.offlineResponse = server.offlineResponse == OfflineResponse::Blank
                          ? FrontEndOptions::OfflineResponse::Blank
                          : FrontEndOptions::OfflineResponse::Exception;
  o.limits.maxWidth = server.limits.maxWidth;
  o.limits.maxHeight = server.limits.maxHeight;
  o.maxMapPixels = server.limits.maxMapPixels;
  o.maxTilesPerMap = static_cast<std::size_t>(server.limits.maxTilesPerMap);
  o.decodedTileCacheBytes = static_cast<std::size_t>(server.limits.decodedTileCache);
  o.jpegQuality = server.jpegQuality;
  o.composeThreads = std::max(1, composeThreads);
  o.maxParamBytes = server.limits.maxParamBytes;
  o.fetchesPerClientPerMinute = server.limits.fetchesPerClientPerMinute;
  o.cdn = cdnOptions(server.cdn);
  return o;
}

CdnOptions cdnOptions(const CdnSettings& cdn) {
  CdnOptions o;
  o.sMaxAge = cdn.sMaxAge;
  o.staleWhileRevalidate = cdn.staleWhileRevalidate;
  o.staleIfError = cdn.staleIfError;
  o.shortMaxAge = cdn.shortMaxAge;
  o.keyHeader = cdn.keyHeader;
  o.purge = cdn.purge;
  return o;
}

HttpServerOptions httpServerOptions(const ServerSettings& server) {
  HttpServerOptions o;
  o.host = server.listenHost;
  o.port = server.listenPort;
  o.maxConnections = static_cast<std::size_t>(std::max(1, server.limits.maxConnections));
  o.maxHeaderBytes = server.limits.maxHeaderBytes;
  o.requestTimeout = server.limits.requestTimeout;
  o.keepAliveTimeout = server.limits.keepaliveTimeout;
  o.requestsPerSecond = server.limits.requestsPerSecond;
  o.threads = server.threads;
  return o;
}

} // namespace tellus::cli
