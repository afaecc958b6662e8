// The configuration in the proxy's terms (tools/tellus/cli): every field of YAML `upstreams`,
// `layers` and `server` lands in the proxy's option of the same meaning, the enums map one to
// one, and values outside the proxy's ranges are clamped.

#include <tellus/cli/ProxyFromConfig.hpp>

#include <gtest/gtest.h>

#include <chrono>
#include <limits>
#include <string>

namespace tellus::cli {
namespace {

using namespace std::chrono_literals;

UpstreamConfig remoteUpstream() {
  UpstreamConfig u;
  u.name = "gibs";
  u.type = UpstreamConfig::Type::Wms;
  u.url = "https://example.org/wms?map=x";
  u.wmsVersion = "1.1.1";
  u.crs = "CRS:84";
  u.connectTimeout = 1234ms;
  u.timeout = 5678ms;
  u.retryBackoff = 91ms;
  u.openInterval = 4321ms;
  u.maxRetryAfterWait = 777ms;
  u.maxConnections = 9;
  u.retries = 7;
  u.metaTiles = 3;
  u.failureThreshold = 11;
  u.headers = {{"Authorization", "Bearer x"}, {"X-A", "1"}};
  u.redirects = RedirectPolicy::Any;
  return u;
}

TEST(ProxyFromConfig, UpstreamKeepsEveryFieldAndPolicy) {
  const UpstreamSpec s = upstreamSpec(remoteUpstream());
  EXPECT_EQ(s.name, "gibs");
  EXPECT_EQ(s.type, UpstreamSpec::Type::Wms);
  EXPECT_EQ(s.url, "https://example.org/wms?map=x");
  EXPECT_EQ(s.wmsVersion, "1.1.1");
  EXPECT_EQ(s.crs, "CRS:84");
  EXPECT_EQ(s.metaTiles, 3);
  EXPECT_EQ(s.policy.maxConnections, 9);
  EXPECT_EQ(s.policy.connectTimeout, 1234ms);
  EXPECT_EQ(s.policy.timeout, 5678ms);
  EXPECT_EQ(s.policy.retries, 7);
  EXPECT_EQ(s.policy.retryBackoff, 91ms);
  EXPECT_EQ(s.policy.failureThreshold, 11);
  EXPECT_EQ(s.policy.openInterval, 4321ms);
  EXPECT_EQ(s.policy.maxRetryAfterWait, 777ms);
  EXPECT_EQ(s.policy.headers, remoteUpstream().headers);
  EXPECT_EQ(s.policy.redirects, UpstreamPolicy::Redirects::Any);
  // What the configuration does not set keeps the proxy's default.
  EXPECT_EQ(s.policy.maxBodyBytes, UpstreamPolicy{}.maxBodyBytes);
  EXPECT_EQ(s.policy.maxRedirects, UpstreamPolicy{}.maxRedirects);
}

TEST(ProxyFromConfig, UpstreamTypesAndRedirectPoliciesMapOneToOne) {
  UpstreamConfig u;
  u.type = UpstreamConfig::Type::Local;
  u.path = "/data/bmng.jpg";
  EXPECT_EQ(upstreamSpec(u).type, UpstreamSpec::Type::Local);
  EXPECT_EQ(upstreamSpec(u).path, "/data/bmng.jpg");
  u.type = UpstreamConfig::Type::Wms;
  EXPECT_EQ(upstreamSpec(u).type, UpstreamSpec::Type::Wms);
  u.type = UpstreamConfig::Type::WorldWind;
  EXPECT_EQ(upstreamSpec(u).type, UpstreamSpec::Type::WorldWind);
  u.type = UpstreamConfig::Type::Wmts;
  EXPECT_EQ(upstreamSpec(u).type, UpstreamSpec::Type::Wmts);
  EXPECT_EQ(upstreamSpec(u).wmtsEncoding, WmtsEncoding::Auto);
  u.encoding = UpstreamConfig::Encoding::Rest;
  EXPECT_EQ(upstreamSpec(u).wmtsEncoding, WmtsEncoding::Rest);
  u.encoding = UpstreamConfig::Encoding::Kvp;
  EXPECT_EQ(upstreamSpec(u).wmtsEncoding, WmtsEncoding::Kvp);
  u.redirects = RedirectPolicy::SameOrigin;
  EXPECT_EQ(upstreamSpec(u).policy.redirects, UpstreamPolicy::Redirects::SameOrigin);
  u.redirects = RedirectPolicy::Any;
  EXPECT_EQ(upstreamSpec(u).policy.redirects, UpstreamPolicy::Redirects::Any);
  u.redirects = RedirectPolicy::None;
  EXPECT_EQ(upstreamSpec(u).policy.redirects, UpstreamPolicy::Redirects::None);
}

TEST(ProxyFromConfig, LayerKeepsEveryField) {
  LayerConfig l;
  l.name = "sst";
  l.title = "Sea surface temperature";
  l.abstract = "GHRSST";
  l.kind = LayerKind::Imagery;
  l.upstream = "gibs";
  l.upstreamLayer = "GHRSST_L4";
  l.tileMatrixSet = "1km";
  l.firstLevel = 2;
  l.dataset.server = "gibs";
  l.dataset.name = "sst";
  l.dataset.mimeType = "image/png";
  l.dataset.pinned = true;
  l.dataset.body = "mars"; // issue 26: the body travels inside the dataset
  l.ttl = 3600000ms;
  l.maxAge = 600s;
  l.opacity = 0.25;
  l.time.values = {"2024-01-01", "2024-01-02"};
  l.time.period = "2024-01-01/2024-01-02/P1D";
  l.time.defaultValue = "2024-01-02";
  const LayerSpec s = layerSpec(l);
  EXPECT_EQ(s.name, "sst");
  EXPECT_EQ(s.title, "Sea surface temperature");
  EXPECT_EQ(s.abstract, "GHRSST");
  EXPECT_EQ(s.upstream, "gibs");
  EXPECT_EQ(s.upstreamLayer, "GHRSST_L4");
  EXPECT_EQ(s.tileMatrixSet, "1km");
  EXPECT_EQ(s.firstLevel, 2);
  EXPECT_EQ(s.dataset.server, "gibs");
  EXPECT_EQ(s.dataset.name, "sst");
  EXPECT_EQ(s.dataset.mimeType, "image/png");
  EXPECT_TRUE(s.dataset.pinned);
  EXPECT_EQ(s.dataset.body, "mars");
  EXPECT_FALSE(s.elevation);
  EXPECT_EQ(s.ttl, 3600000ms);
  EXPECT_EQ(s.maxAge, 600s);
  EXPECT_EQ(s.opacity, 0.25);
  EXPECT_EQ(s.timeValues, l.time.values);
  EXPECT_EQ(s.timePeriod, "2024-01-01/2024-01-02/P1D");
  EXPECT_EQ(s.timeDefault, "2024-01-02");
}

TEST(ProxyFromConfig, ElevationNoDataIsClampedIntoSixteenBits) {
  LayerConfig l;
  l.kind = LayerKind::Elevation;
  const auto noData = [&](double v) {
    l.elevation.noData = v;
    return layerSpec(l).noData;
  };
  EXPECT_TRUE(layerSpec(l).elevation);
  EXPECT_EQ(noData(-32768.0), -32768);
  EXPECT_EQ(noData(-9999.0), -9999);
  EXPECT_EQ(noData(0.0), 0);
  EXPECT_EQ(noData(32767.0), 32767);
  EXPECT_EQ(noData(-1e300), -32768);
  EXPECT_EQ(noData(1e300), 32767);
  EXPECT_EQ(noData(-std::numeric_limits<double>::infinity()), -32768);
  EXPECT_EQ(noData(-9999.9), -9999); // toward zero, as a cast does
}

// A value layer's tiles from a local raster carry its own no-data sample (values.no_data), else
// the default -32768.
TEST(ProxyFromConfig, ValueLayerNoDataIsItsOwn) {
  LayerConfig l;
  l.kind = LayerKind::Values;
  EXPECT_EQ(layerSpec(l).noData, -32768);
  l.values.format.noData = -9999.0;
  EXPECT_EQ(layerSpec(l).noData, -9999);
  l.values.format.noData = 1e9;
  EXPECT_EQ(layerSpec(l).noData, 32767);
  l.kind = LayerKind::Imagery; // not a value layer: the elevation setting, as before
  EXPECT_EQ(layerSpec(l).noData, -32768);
}

// Value layers (issue 24): a value layer's default style is its colour map; an elevation
// layer's stays the uncoloured one; the styles default to every colour map; imagery has none.
TEST(ProxyFromConfig, ValueLayersCarryTheirFormatStylesAndScale) {
  LayerConfig l;
  l.kind = LayerKind::Values;
  l.values.format.container = values::Container::Tiff;
  l.values.format.encoding = values::Encoding::Float32;
  l.values.format.unit = "K";
  l.values.colourMap = "magma";
  l.values.styles = {"magma", "cividis"};
  l.values.rangeFromData = true;
  l.values.lowPercent = 2;
  l.values.highPercent = 98;
  l.values.scaling = values::Scaling::Log;
  l.values.outOfRange = values::OutOfRange::Transparent;
  const LayerSpec s = layerSpec(l);
  ASSERT_TRUE(s.values);
  EXPECT_FALSE(s.elevation);
  EXPECT_EQ(s.values->format.container, values::Container::Tiff);
  EXPECT_EQ(s.values->format.unit, "K");
  EXPECT_EQ(s.values->defaultStyle, "magma");
  EXPECT_EQ(s.values->styles, (std::vector<std::string>{"magma", "cividis"}));
  EXPECT_TRUE(s.values->rangeFromData);
  EXPECT_EQ(s.values->lowPercent, 2);
  EXPECT_EQ(s.values->highPercent, 98);
  EXPECT_EQ(s.values->scaling, values::Scaling::Log);
  EXPECT_EQ(s.values->outOfRange, values::OutOfRange::Transparent);

  LayerConfig e;
  e.kind = LayerKind::Elevation;
  const LayerSpec es = layerSpec(e);
  ASSERT_TRUE(es.values);
  EXPECT_EQ(es.values->defaultStyle, "");
  EXPECT_EQ(es.values->styles.size(), values::colourMaps().size());

  EXPECT_FALSE(layerSpec(LayerConfig{}).values);
}

TEST(ProxyFromConfig, TheEmbeddedDefaultInOrder) {
  const Config c = embeddedDefault(TELLUS_TEST_DATA_DIR, TELLUS_TEST_TMP_DIR);
  ASSERT_TRUE(validate(c));
  const ProxySpecs specs = proxySpecs(c);
  ASSERT_EQ(specs.upstreams.size(), c.upstreams.size());
  ASSERT_EQ(specs.layers.size(), c.layers.size());
  ASSERT_FALSE(specs.layers.empty());
  for (std::size_t i = 0; i < c.upstreams.size(); ++i)
    EXPECT_EQ(specs.upstreams[i].name, c.upstreams[i].name);
  for (std::size_t i = 0; i < c.layers.size(); ++i) {
    EXPECT_EQ(specs.layers[i].name, c.layers[i].name);
    EXPECT_EQ(specs.layers[i].elevation, c.layers[i].kind == LayerKind::Elevation);
  }
}

ServerSettings busyServer() {
  ServerSettings s;
  s.listenHost = "::";
  s.listenPort = 8081;
  s.publicUrl = "https://tiles.example.org/";
  s.cors = "";
  s.exceptionsHttpStatus = true;
  s.offlineResponse = OfflineResponse::Blank;
  s.offline = true;
  s.threads = 3;
  s.jpegQuality = 77;
  s.limits.maxConnections = 100;
  s.limits.maxHeaderBytes = 8192;
  s.limits.maxParamBytes = 1024;
  s.limits.maxWidth = 2048;
  s.limits.maxHeight = 1024;
  s.limits.requestTimeout = 2500ms;
  s.limits.keepaliveTimeout = 0ms;
  s.limits.requestsPerSecond = 12.5;
  s.limits.fetchesPerClientPerMinute = 30.0;
  s.limits.maxMapPixels = 1000000;
  s.limits.maxTilesPerMap = 64;
  s.limits.decodedTileCache = 5u << 20;
  s.cdn.sMaxAge = std::chrono::seconds(7200);
  s.cdn.staleWhileRevalidate = std::chrono::seconds(30);
  s.cdn.staleIfError = std::chrono::seconds(0);
  s.cdn.shortMaxAge = std::chrono::seconds(5);
  s.cdn.keyHeader = "Surrogate-Key";
  s.cdn.purge = {"http://127.0.0.1:6081/"};
  return s;
}

TEST(ProxyFromConfig, FrontEndKeepsEveryServerSetting) {
  const FrontEndOptions o = frontEndOptions(busyServer(), 6);
  EXPECT_EQ(o.publicUrl, "https://tiles.example.org/");
  EXPECT_EQ(o.cors, "");
  EXPECT_TRUE(o.exceptionsHttpStatus);
  EXPECT_EQ(o.offlineResponse, FrontEndOptions::OfflineResponse::Blank);
  EXPECT_EQ(o.limits.maxWidth, 2048);
  EXPECT_EQ(o.limits.maxHeight, 1024);
  EXPECT_EQ(o.maxMapPixels, 1000000);
  EXPECT_EQ(o.maxTilesPerMap, 64u);
  EXPECT_EQ(o.decodedTileCacheBytes, std::size_t{5} << 20);
  EXPECT_EQ(o.jpegQuality, 77);
  EXPECT_EQ(o.composeThreads, 6);
  EXPECT_EQ(o.maxParamBytes, 1024u);
  EXPECT_EQ(o.fetchesPerClientPerMinute, 30.0);
  EXPECT_EQ(o.cdn.sMaxAge, std::chrono::seconds(7200));
  EXPECT_EQ(o.cdn.staleWhileRevalidate, std::chrono::seconds(30));
  EXPECT_EQ(o.cdn.staleIfError, std::chrono::seconds(0));
  EXPECT_EQ(o.cdn.shortMaxAge, std::chrono::seconds(5));
  EXPECT_EQ(o.cdn.keyHeader, "Surrogate-Key");
  EXPECT_EQ(o.cdn.purge, std::vector<std::string>{"http://127.0.0.1:6081/"});
  EXPECT_EQ(frontEndOptions(ServerSettings{}, 1).offlineResponse,
            FrontEndOptions::OfflineResponse::Exception);
  // No core count known (hardware_concurrency() is 0): one worker all the same.
  EXPECT_EQ(frontEndOptions(ServerSettings{}, 0).composeThreads, 1);
}

TEST(ProxyFromConfig, HttpServerKeepsEveryServerSetting) {
  const HttpServerOptions o = httpServerOptions(busyServer());
  EXPECT_EQ(o.host, "::");
  EXPECT_EQ(o.port, 8081);
  EXPECT_EQ(o.threads, 3);
  EXPECT_EQ(o.maxConnections, 100u);
  EXPECT_EQ(o.maxHeaderBytes, 8192u);
  EXPECT_EQ(o.requestTimeout, 2500ms);
  EXPECT_EQ(o.keepAliveTimeout, 0ms);
  EXPECT_EQ(o.requestsPerSecond, 12.5);
  EXPECT_EQ(o.serverName, HttpServerOptions{}.serverName);
  // A configuration of no connections still accepts one.
  ServerSettings none;
  none.limits.maxConnections = 0;
  EXPECT_EQ(httpServerOptions(none).maxConnections, 1u);
  none.limits.maxConnections = -5;
  EXPECT_EQ(httpServerOptions(none).maxConnections, 1u);
}

TEST(ProxyFromConfig, TileServiceIsOfflineWhenTheServerIs) {
  EXPECT_TRUE(tileServiceOptions(busyServer()).offline);
  const TileServiceOptions o = tileServiceOptions(ServerSettings{});
  EXPECT_FALSE(o.offline);
  EXPECT_EQ(o.renderThreads, TileServiceOptions{}.renderThreads);
  EXPECT_EQ(o.workerNice, 0);
}

} // namespace
} // namespace tellus::cli
