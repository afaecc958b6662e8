// YAML configurations: the examples, defaults, every key, and errors that name file, line and key.

#include "../support/TempDir.hpp"

#include <tellus/config/Config.hpp>

#include <gtest/gtest.h>

#include <fstream>
#include <string>

using namespace tellus;
namespace fs = std::filesystem;
using std::chrono::milliseconds;
using std::chrono::seconds;

namespace {

const fs::path kData = TELLUS_TEST_DATA_DIR;
const fs::path kExamples = kData.parent_path() / "config" / "examples";

/** A valid configuration with a WMS upstream; tests append to it or replace parts. */
constexpr std::string_view kMinimal = R"(upstreams:
  - name: up
    type: wms
    url: http://example.org/wms
layers:
  - name: a
    upstream: up
    format: image/jpeg
    grid:
      levels: 3
)";

std::expected<Config, ConfigError> parse(std::string_view yaml, const fs::path& base = "/base") {
  return parseConfig(yaml, "test.yaml", base);
}

/** The error of a configuration that must not parse. */
ConfigError errorOf(std::string_view yaml, const fs::path& base = "/base") {
  auto c = parse(yaml, base);
  EXPECT_FALSE(c) << "parsed although it should not:\n" << yaml;
  if (c) return {};
  EXPECT_EQ(c.error().file, "test.yaml");
  return c.error();
}

/** text with the first `from` replaced by `to`. */
std::string swap(std::string_view text, std::string_view from, std::string_view to) {
  std::string s(text);
  const auto at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) s.replace(at, from.size(), to);
  return s;
}

void writeFile(const fs::path& p, std::string_view text) {
  fs::create_directories(p.parent_path());
  std::ofstream out(p, std::ios::binary);
  out << text;
}

} // namespace

// ---- examples and defaults ---------------------------------------------------------------------

TEST(ConfigYaml, EveryExampleParses) {
  for (const char* name : {"default.yaml",
                           "mapserver.yaml",
                           "public.yaml",
                           "heights.yaml",
                           "sst.yaml",
                           "planetary.yaml"}) {
    const auto c = loadConfig(kExamples / name);
    ASSERT_TRUE(c) << c.error().toString();
    EXPECT_EQ(c->sourceFile, kExamples / name);
    EXPECT_FALSE(c->layers.empty()) << name;
    EXPECT_TRUE(validate(*c)) << name;
  }
}

// The thesis's figure 25 (issue 24): heights as a value layer over the Blue Marble.
TEST(ConfigYaml, HeightsExample) {
  const auto c = loadConfig(kExamples / "heights.yaml");
  ASSERT_TRUE(c) << c.error().toString();
  const LayerConfig* h = c->layer("heights");
  ASSERT_NE(h, nullptr);
  EXPECT_EQ(h->kind, LayerKind::Values);
  EXPECT_EQ(h->values.colourMap, "terrain");
  EXPECT_EQ(h->values.min, -8000.0);
  ASSERT_EQ(c->renderer.layers.size(), 2u);
  EXPECT_EQ(c->renderer.layers[1].layer, "heights");
  EXPECT_EQ(c->renderer.layers[1].opacity, 0.5);
}

// Real data as values (issue 24): the bundled COADS SST, hundredths of a degree C, land no data.
TEST(ConfigYaml, SeaSurfaceTemperatureExample) {
  const auto c = loadConfig(kExamples / "sst.yaml");
  ASSERT_TRUE(c) << c.error().toString();
  const LayerConfig* sst = c->layer("sst");
  ASSERT_NE(sst, nullptr);
  EXPECT_EQ(sst->kind, LayerKind::Values);
  EXPECT_EQ(sst->dataset.mimeType, "application/bil16");
  EXPECT_EQ(sst->values.format.encoding, values::Encoding::Int16);
  EXPECT_EQ(sst->values.format.scale, 0.01);
  EXPECT_EQ(sst->values.format.noData, -32768.0);
  EXPECT_EQ(sst->values.format.unit, "°C");
  EXPECT_EQ(sst->values.colourMap, "magma");
  EXPECT_EQ(sst->values.min, -2.0);
  EXPECT_EQ(sst->values.max, 32.0);
  const UpstreamConfig* up = c->upstream(sst->upstream);
  ASSERT_NE(up, nullptr);
  EXPECT_EQ(up->type, UpstreamConfig::Type::Local);
  EXPECT_TRUE(fs::exists(up->path)) << up->path; // the bundled file, through data_dir
  EXPECT_EQ(up->path.filename(), "sst_coads_jan_int16.tif");
  ASSERT_EQ(c->renderer.layers.size(), 2u);
  EXPECT_EQ(c->renderer.layers[1].layer, "sst");
}

// renderer.layers[i].colour_map and range: value layers only, known maps, min < max.
TEST(ConfigYaml, RendererValueOverrides) {
  const auto c = loadConfig(kExamples / "heights.yaml");
  ASSERT_TRUE(c);
  Config ok = *c;
  ok.renderer.layers[1].colourMap = "viridis";
  ok.renderer.layers[1].range = std::array<double, 2>{-100.0, 100.0};
  EXPECT_TRUE(validate(ok));
  Config badMap = *c;
  badMap.renderer.layers[1].colourMap = "nope";
  ASSERT_FALSE(validate(badMap));
  EXPECT_NE(validate(badMap).error().find("layers[1].colour_map"), std::string::npos);
  Config badRange = *c;
  badRange.renderer.layers[1].range = std::array<double, 2>{5.0, 5.0};
  ASSERT_FALSE(validate(badRange));
  EXPECT_NE(validate(badRange).error().find("layers[1].range"), std::string::npos);
  Config onImagery = *c;
  onImagery.renderer.layers[0].colourMap = "viridis";
  EXPECT_FALSE(validate(onImagery));
  Config valueBase = *c;
  std::swap(valueBase.renderer.layers[0], valueBase.renderer.layers[1]);
  valueBase.renderer.layers[0].opacity.reset();
  EXPECT_FALSE(validate(valueBase)); // the base is imagery
}

TEST(ConfigYaml, MapserverExample) {
  const auto c = loadConfig(kExamples / "mapserver.yaml");
  ASSERT_TRUE(c) << c.error().toString();
  const UpstreamConfig* ms = c->upstream("mapserver");
  ASSERT_NE(ms, nullptr);
  EXPECT_EQ(ms->type, UpstreamConfig::Type::Wms);
  EXPECT_TRUE(ms->url.starts_with("http://127.0.0.1:8081/cgi-bin/mapserv?map="));
  EXPECT_EQ(ms->wmsVersion, "1.3.0");
  EXPECT_EQ(ms->crs, "EPSG:4326");
  const LayerConfig* bmng = c->layer("bmng");
  ASSERT_NE(bmng, nullptr);
  EXPECT_EQ(bmng->dataset.mimeType, "image/jpeg");
  EXPECT_EQ(bmng->dataset.grid.levelZeroDeltaDeg, 36.0);
  EXPECT_EQ(bmng->dataset.grid.tileWidth, 512);
  EXPECT_EQ(bmng->dataset.server, "mapserver");
  const LayerConfig* etopo = c->layer("etopo5");
  ASSERT_NE(etopo, nullptr);
  EXPECT_EQ(etopo->kind, LayerKind::Elevation);
  EXPECT_EQ(etopo->dataset.mimeType, "application/bil16");
  EXPECT_EQ(etopo->dataset.grid.levelZeroDeltaDeg, 20.0);
  EXPECT_EQ(etopo->dataset.grid.tileWidth, 150);
  EXPECT_EQ(etopo->upstreamLayer, "etopo5");
  EXPECT_EQ(c->cache.sizeLimitBytes, 2ULL << 30);
}

TEST(ConfigYaml, PublicExample) {
  const auto c = loadConfig(kExamples / "public.yaml");
  ASSERT_TRUE(c) << c.error().toString();
  const UpstreamConfig* gibs = c->upstream("gibs");
  ASSERT_NE(gibs, nullptr);
  EXPECT_EQ(gibs->url, "https://gibs.earthdata.nasa.gov/wms/epsg4326/best/wms.cgi");
  ASSERT_EQ(gibs->headers.size(), 1U);
  EXPECT_EQ(gibs->headers[0].first, "User-Agent");
  EXPECT_EQ(gibs->retryBackoff, milliseconds(500));
  EXPECT_EQ(c->upstream("neo")->wmsVersion, "1.1.1");
  EXPECT_EQ(c->upstream("ww-tiles")->type, UpstreamConfig::Type::WorldWind);

  const LayerConfig* modis = c->layer("modis-truecolor");
  ASSERT_NE(modis, nullptr);
  EXPECT_EQ(modis->upstreamLayer, "MODIS_Terra_CorrectedReflectance_TrueColor");
  ASSERT_EQ(modis->time.values.size(), 9443U);
  EXPECT_EQ(modis->time.values.front(), "2000-02-24");
  EXPECT_EQ(modis->time.values[6], "2000-03-01"); // 2000 is a leap year
  EXPECT_EQ(modis->time.values.back(), "2025-12-31");
  EXPECT_EQ(modis->time.period, "2000-02-24/2025-12-31/P1D");
  EXPECT_EQ(modis->time.defaultValue, "2025-06-01");

  const UpstreamConfig* wmts = c->upstream("gibs-wmts");
  ASSERT_NE(wmts, nullptr);
  EXPECT_EQ(wmts->type, UpstreamConfig::Type::Wmts);
  EXPECT_EQ(wmts->encoding, UpstreamConfig::Encoding::Rest);
  EXPECT_EQ(wmts->url, "https://gibs.earthdata.nasa.gov/wmts/epsg4326/best/wmts.cgi");
  for (const char* name : {"modis-truecolor-wmts", "sea-surface-temperature-wmts"}) {
    const LayerConfig* l = c->layer(name);
    ASSERT_NE(l, nullptr) << name;
    EXPECT_EQ(l->upstream, "gibs-wmts");
    EXPECT_FALSE(l->tileMatrixSet.empty());
    EXPECT_TRUE(l->time.enabled());
  }
  EXPECT_EQ(c->layer("modis-truecolor-wmts")->tileMatrixSet, "250m");
  // GIBS's Web Mercator endpoint, composed onto the lat/long grid.
  const UpstreamConfig* merc = c->upstream("gibs-wmts-3857");
  ASSERT_NE(merc, nullptr);
  EXPECT_EQ(merc->type, UpstreamConfig::Type::Wmts);
  EXPECT_EQ(merc->url,
            "https://gibs.earthdata.nasa.gov/wmts/epsg3857/best/1.0.0/WMTSCapabilities.xml");
  const LayerConfig* modisMerc = c->layer("modis-truecolor-wmts-3857");
  ASSERT_NE(modisMerc, nullptr);
  EXPECT_EQ(modisMerc->upstream, "gibs-wmts-3857");
  EXPECT_EQ(modisMerc->tileMatrixSet, "GoogleMapsCompatible_Level9");

  const LayerConfig* sst = c->layer("sea-surface-temperature");
  ASSERT_NE(sst, nullptr);
  ASSERT_FALSE(sst->time.values.empty());
  EXPECT_EQ(sst->time.values[1], "2002-08-01");
  EXPECT_EQ(sst->time.defaultValue, "2024-12-01"); // the last value
  EXPECT_FALSE(c->layer("land-temperature-climatology")->time.enabled());

  const LayerConfig* elev = c->layer("earth-elevation");
  ASSERT_NE(elev, nullptr);
  EXPECT_EQ(elev->kind, LayerKind::Elevation);
  EXPECT_EQ(elev->upstreamLayer, "GEBCO,aster_v2,USGS-NED");
  EXPECT_EQ(elev->maxAge, seconds(30 * 86400));
  // Its heights as values (issue 24): colour-map styles over WMS, metres.
  EXPECT_TRUE(elev->isValueLayer());
  EXPECT_EQ(elev->values.colourMap, "terrain");
  EXPECT_EQ(elev->values.styles,
            (std::vector<std::string>{"terrain", "viridis", "cividis", "turbo"}));
  EXPECT_EQ(elev->values.min, -8000.0);
  EXPECT_EQ(elev->values.max, 8000.0);
  EXPECT_EQ(elev->values.format.unit, "m");
  // NEO's and GIBS's WMS layers send coloured pictures, not values (the example says why): they
  // stay imagery.
  for (const char* name : {"bluemarble",
                           "modis-truecolor",
                           "sea-surface-temperature",
                           "land-temperature-climatology"}) {
    ASSERT_NE(c->layer(name), nullptr) << name;
    EXPECT_EQ(c->layer(name)->kind, LayerKind::Imagery) << name;
    EXPECT_FALSE(c->layer(name)->isValueLayer()) << name;
  }
  EXPECT_EQ(c->layer("srtm30plus")->dataset.grid.numLevels, 10);
  EXPECT_TRUE(c->layer("bluemarble")->dataset.pinned);
  EXPECT_EQ(c->server.offlineResponse, OfflineResponse::Blank);
  EXPECT_EQ(c->server.limits.requestsPerSecond, 50.0);
}

TEST(ConfigYaml, DefaultsAreApplied) {
  const auto c = parse(kMinimal);
  ASSERT_TRUE(c) << c.error().toString();
  EXPECT_EQ(c->sourceFile, "test.yaml");
  EXPECT_EQ(c->server.listenHost, "127.0.0.1");
  EXPECT_EQ(c->server.listenPort, 8080);
  EXPECT_EQ(c->server.publicUrl, "");
  EXPECT_EQ(c->server.cors, "*");
  EXPECT_FALSE(c->server.exceptionsHttpStatus);
  EXPECT_EQ(c->server.offlineResponse, OfflineResponse::Exception);
  EXPECT_FALSE(c->server.offline);
  EXPECT_EQ(c->renderer.earth, EarthShape::Wgs84);
  EXPECT_TRUE(c->renderer.geoid);
  EXPECT_EQ(c->renderer.fadeInS, 0.3); // no popping (issue 23): on by default
  EXPECT_TRUE(c->renderer.geomorph);
  EXPECT_FALSE(c->renderer.dome.enabled);
  EXPECT_EQ(c->renderer.dome.fovDeg, 180.0);
  EXPECT_EQ(c->renderer.dome.method, DomeSettings::Method::Direct);
  EXPECT_TRUE(c->renderer.stars.enabled); // the stars are on by default (issue 23)
  EXPECT_EQ(c->renderer.stars.magnitudeLimit, 6.5);
  EXPECT_EQ(c->renderer.stars.brightness, 1.0);
  EXPECT_TRUE(c->renderer.atmosphere.enabled);
  EXPECT_EQ(c->renderer.atmosphere.topAltitude, 60000.0);
  EXPECT_EQ(c->server.limits.maxConnections, 4096);
  EXPECT_EQ(c->server.limits.maxHeaderBytes, 16384U);
  EXPECT_EQ(c->server.limits.maxParamBytes, 2048U);
  EXPECT_EQ(c->server.limits.maxWidth, 4096);
  EXPECT_EQ(c->server.limits.maxHeight, 4096);
  EXPECT_EQ(c->server.limits.requestTimeout, seconds(10));
  EXPECT_EQ(c->server.limits.keepaliveTimeout, seconds(60));
  EXPECT_EQ(c->server.limits.requestsPerSecond, 0.0);
  EXPECT_EQ(c->cache.root, defaultCacheRoot());
  EXPECT_EQ(c->cache.sizeLimitBytes, 0U);
  EXPECT_EQ(c->cache.keepUnstoredBytes, 64ULL << 20);

  const UpstreamConfig& u = c->upstreams.at(0);
  EXPECT_EQ(u.wmsVersion, "1.3.0");
  EXPECT_EQ(u.crs, "EPSG:4326");
  EXPECT_EQ(u.connectTimeout, seconds(5));
  EXPECT_EQ(u.timeout, seconds(30));
  EXPECT_EQ(u.retryBackoff, milliseconds(200));
  EXPECT_EQ(u.openInterval, seconds(30));
  EXPECT_EQ(u.maxConnections, 4);
  EXPECT_EQ(u.retries, 3);
  EXPECT_EQ(u.failureThreshold, 5);
  EXPECT_EQ(u.metaTiles, 4);
  EXPECT_TRUE(u.headers.empty());

  const LayerConfig& l = c->layers.at(0);
  EXPECT_EQ(l.title, "a");
  EXPECT_EQ(l.abstract, "");
  EXPECT_EQ(l.upstreamLayer, "a");
  EXPECT_EQ(l.kind, LayerKind::Imagery);
  EXPECT_EQ(l.firstLevel, 0);
  EXPECT_EQ(l.dataset.server, "up");
  EXPECT_EQ(l.dataset.name, "a");
  EXPECT_EQ(l.dataset.extension, "jpg");
  EXPECT_EQ(l.dataset.style, "");
  EXPECT_EQ(l.dataset.time, "");
  EXPECT_FALSE(l.dataset.pinned);
  EXPECT_EQ(l.dataset.grid, (GridSpec{Sector{}, 36.0, 512, 512, 3}));
  EXPECT_FALSE(l.time.enabled());
  EXPECT_EQ(l.ttl, milliseconds(0));
  EXPECT_EQ(l.maxAge, seconds(86400));
}

TEST(ConfigYaml, EveryKeyIsRead) {
  const auto c = parse(R"(
server:
  listen: "[::1]:0"
  public_url: https://tiles.example.org/tellus/
  cors: ""
  exceptions_http_status: true
  offline_response: blank
  offline: yes
  jpeg_quality: 85
  limits:
    max_connections: 10
    max_header_bytes: 8KiB
    max_param_bytes: 1000
    max_width: 2048
    max_height: 1024
    request_timeout: 500ms
    keepalive_timeout: 0
    requests_per_second: 2.5
    fetches_per_client_per_minute: 120
    max_map_pixels: 1000000
    max_tiles_per_map: 64
    decoded_tile_cache: 8MiB
cache:
  root: cache/here
  size_limit: 10GiB
  keep_unstored: 8MiB
renderer:
  lod_threshold: 1.5
  mesh_size: 17
  fov: 60
  overview: pic
  texture_budget: 256MiB
  upload_per_frame: 2MiB
  max_in_flight: 4
  max_splits_per_frame: 8
  decode_threads: 3
  earth: sphere
  geoid: false
  overlays_per_pass: 2
  time: 2024-06-20T18:30:00Z
  sunlight: false
  night: false
  fade_in: 0.5
  geomorph: false
  dome: {enabled: true, fov: 210, tilt: 30, face_scale: 0.8, method: cube, direct_max_error: 2}
  stars: {enabled: false, magnitude_limit: 5, brightness: 2.5}
  atmosphere: {enabled: false, exposure: 4, resolution: quarter, top_altitude: 80000, mie_g: 0.7,
               rayleigh_scattering: [1e-6, 2e-6, 3e-6], ground_albedo: [0.3, 0.3, 0.3]}
upstreams:
  - name: ww
    type: worldwind
    url: https://ww.example.org/tiles.aspx?key=1
    connect_timeout: 1s
    timeout: 2m
    max_connections: 16
    retries: 0
    retry_backoff: 0
    failure_threshold: 1
    open_interval: 1h
    max_retry_after_wait: 90s
    headers: {User-Agent: "tellus/0.1", Referer: "https://example.org/"}
    redirects: any
  - name: w
    type: wms
    url: http://127.0.0.1:9/wms
    version: 1.1.1
    crs: CRS:84
    meta_tiles: 1
layers:
  - name: heights.v2
    title: Heights
    abstract: "SRTM heights"
    upstream: ww
    upstream_layer: srtm30
    style: ""
    format: image/png
    kind: elevation
    grid:
      sector: [-10, -20.5, 30, 40]
      level_zero_delta: 20
      tile_size: [150, 100]
      levels: 5
      first_level: 2
    elevation:
      encoding: png16
      scale: 0.5
      offset: -1000
      no_data: 0
    time:
      values: [2024-01-01, 2024-01-02]
      default: 2024-01-01
    cache:
      ttl: 12h
      pinned: true
      max_age: 5m
  - name: pic
    upstream: w
    style: rainbow
    format: image/tiff
    kind: imagery
    opacity: 0.4
    grid: {levels: 1, level_zero_delta: 45, tile_size: 256}
)",
                       "/srv/conf");
  ASSERT_TRUE(c) << c.error().toString();
  const ServerSettings& s = c->server;
  EXPECT_EQ(s.listenHost, "::1");
  EXPECT_EQ(s.listenPort, 0);
  EXPECT_EQ(s.publicUrl, "https://tiles.example.org/tellus/");
  EXPECT_EQ(s.cors, "");
  EXPECT_TRUE(s.exceptionsHttpStatus);
  EXPECT_EQ(s.offlineResponse, OfflineResponse::Blank);
  EXPECT_TRUE(s.offline);
  EXPECT_EQ(s.limits.maxConnections, 10);
  EXPECT_EQ(s.limits.maxHeaderBytes, 8192U);
  EXPECT_EQ(s.limits.maxParamBytes, 1000U);
  EXPECT_EQ(s.limits.maxWidth, 2048);
  EXPECT_EQ(s.limits.maxHeight, 1024);
  EXPECT_EQ(s.limits.requestTimeout, milliseconds(500));
  EXPECT_EQ(s.limits.keepaliveTimeout, milliseconds(0));
  EXPECT_EQ(s.limits.requestsPerSecond, 2.5);
  EXPECT_EQ(s.limits.fetchesPerClientPerMinute, 120.0);
  EXPECT_EQ(s.limits.maxMapPixels, 1000000);
  EXPECT_EQ(s.limits.maxTilesPerMap, 64);
  EXPECT_EQ(s.limits.decodedTileCache, 8ULL << 20);
  EXPECT_EQ(s.jpegQuality, 85);
  EXPECT_EQ(c->cache.root, "/srv/conf/cache/here");
  EXPECT_EQ(c->cache.sizeLimitBytes, 10ULL << 30);
  EXPECT_EQ(c->cache.keepUnstoredBytes, 8ULL << 20);
  EXPECT_EQ(c->renderer.lodThreshold, 1.5);
  EXPECT_EQ(c->renderer.meshSize, 17);
  EXPECT_EQ(c->renderer.fovDeg, 60.0);
  EXPECT_EQ(c->renderer.overview, "pic");
  EXPECT_EQ(c->renderer.textureBudget, 256ULL << 20);
  EXPECT_EQ(c->renderer.uploadPerFrame, 2ULL << 20);
  EXPECT_EQ(c->renderer.maxInFlight, 4);
  EXPECT_EQ(c->renderer.maxSplitsPerFrame, 8);
  EXPECT_TRUE(c->renderer.dome.enabled);
  EXPECT_EQ(c->renderer.dome.fovDeg, 210.0);
  EXPECT_EQ(c->renderer.dome.tiltDeg, 30.0);
  EXPECT_EQ(c->renderer.dome.faceScale, 0.8);
  EXPECT_EQ(c->renderer.dome.method, DomeSettings::Method::Cube);
  EXPECT_EQ(c->renderer.dome.directMaxErrorPx, 2.0);
  EXPECT_FALSE(c->renderer.stars.enabled);
  EXPECT_EQ(c->renderer.stars.magnitudeLimit, 5.0);
  EXPECT_EQ(c->renderer.stars.brightness, 2.5);
  EXPECT_FALSE(c->renderer.atmosphere.enabled);
  EXPECT_EQ(c->renderer.atmosphere.exposure, 4.0);
  EXPECT_EQ(c->renderer.atmosphere.resolutionDivisor, 4);
  EXPECT_EQ(c->renderer.atmosphere.topAltitude, 80000.0);
  EXPECT_EQ(c->renderer.atmosphere.mieG, 0.7);
  EXPECT_EQ(c->renderer.atmosphere.rayleighScattering[2], 3e-6);
  EXPECT_EQ(c->renderer.atmosphere.groundAlbedo[0], 0.3);
  EXPECT_EQ(c->renderer.decodeThreads, 3);
  EXPECT_EQ(c->renderer.earth, EarthShape::Sphere);
  EXPECT_FALSE(c->renderer.geoid);
  EXPECT_EQ(c->renderer.overlaysPerPass, 2);
  EXPECT_EQ(c->renderer.time, "2024-06-20T18:30:00Z");
  EXPECT_FALSE(c->renderer.sunlight);
  EXPECT_FALSE(c->renderer.night);
  EXPECT_EQ(c->renderer.fadeInS, 0.5);
  EXPECT_FALSE(c->renderer.geomorph);

  const UpstreamConfig& ww = c->upstreams.at(0);
  EXPECT_EQ(ww.type, UpstreamConfig::Type::WorldWind);
  EXPECT_EQ(ww.url, "https://ww.example.org/tiles.aspx?key=1");
  EXPECT_EQ(ww.connectTimeout, seconds(1));
  EXPECT_EQ(ww.timeout, std::chrono::minutes(2));
  EXPECT_EQ(ww.maxConnections, 16);
  EXPECT_EQ(ww.retries, 0);
  EXPECT_EQ(ww.retryBackoff, milliseconds(0));
  EXPECT_EQ(ww.failureThreshold, 1);
  EXPECT_EQ(ww.openInterval, std::chrono::hours(1));
  EXPECT_EQ(ww.maxRetryAfterWait, seconds(90));
  ASSERT_EQ(ww.headers.size(), 2U);
  EXPECT_EQ(ww.headers[0], (std::pair<std::string, std::string>{"User-Agent", "tellus/0.1"}));
  EXPECT_EQ(ww.headers[1].first, "Referer");
  EXPECT_EQ(ww.redirects, RedirectPolicy::Any);
  const UpstreamConfig& w = c->upstreams.at(1);
  EXPECT_EQ(w.wmsVersion, "1.1.1");
  EXPECT_EQ(w.crs, "CRS:84");
  EXPECT_EQ(w.metaTiles, 1);

  const LayerConfig& l = c->layers.at(0);
  EXPECT_EQ(l.name, "heights.v2");
  EXPECT_EQ(l.title, "Heights");
  EXPECT_EQ(l.abstract, "SRTM heights");
  EXPECT_EQ(l.upstream, "ww");
  EXPECT_EQ(l.upstreamLayer, "srtm30");
  EXPECT_EQ(l.kind, LayerKind::Elevation);
  EXPECT_EQ(l.dataset.mimeType, "image/png");
  EXPECT_EQ(l.dataset.extension, "png");
  EXPECT_EQ(l.dataset.grid, (GridSpec{Sector{-10, -20.5, 30, 40}, 20.0, 150, 100, 5}));
  EXPECT_EQ(l.firstLevel, 2);
  EXPECT_EQ(l.elevation.encoding, ElevationEncoding::Png16);
  EXPECT_EQ(l.elevation.scale, 0.5);
  EXPECT_EQ(l.elevation.offset, -1000.0);
  EXPECT_EQ(l.elevation.noData, 0.0);
  EXPECT_EQ(l.time.values, (std::vector<std::string>{"2024-01-01", "2024-01-02"}));
  EXPECT_EQ(l.time.period, "");
  EXPECT_EQ(l.time.defaultValue, "2024-01-01");
  EXPECT_EQ(l.ttl, std::chrono::hours(12));
  EXPECT_TRUE(l.dataset.pinned);
  EXPECT_EQ(l.maxAge, seconds(300));
  const LayerConfig& pic = c->layers.at(1);
  EXPECT_EQ(pic.kind, LayerKind::Imagery); // tiff defaults to elevation; kind overrides it
  EXPECT_EQ(pic.dataset.style, "rainbow");
  EXPECT_EQ(pic.opacity, 0.4);
  EXPECT_EQ(l.opacity, 1.0);
  EXPECT_EQ(pic.dataset.extension, "tif");
  EXPECT_EQ(pic.dataset.grid.levelZeroDeltaDeg, 45.0);
}

TEST(ConfigYaml, KindFollowsTheFormat) {
  std::string yaml(kMinimal);
  yaml.replace(yaml.find("image/jpeg"), 10, "image/tiff");
  const auto c = parse(yaml);
  ASSERT_TRUE(c) << c.error().toString();
  EXPECT_EQ(c->layers[0].kind, LayerKind::Elevation);
  EXPECT_EQ(c->layers[0].elevation.encoding, ElevationEncoding::Int16Tiff);
  EXPECT_EQ(c->layers[0].dataset.extension, "tif");
}

TEST(ConfigYaml, TimeValuesAndPeriods) {
  const auto c = parse(std::string(kMinimal) + R"(    time:
      period: 2024-01-30/2024-05-31/P1M
  - name: hourly
    upstream: up
    format: image/png
    grid: {levels: 1}
    time:
      period: 2024-03-01T00:00:00Z/2024-03-01T12:00:00Z/PT6H
      default: 2024-03-01T06:00:00Z
  - name: day-in-hours
    upstream: up
    format: image/png
    grid: {levels: 1}
    time: {period: 2024-01-01/2024-01-02/PT12H}
)");
  ASSERT_TRUE(c) << c.error().toString();
  // Months are added on the calendar from the start: the 30th becomes the 29th in February 2024.
  EXPECT_EQ(c->layers[0].time.values,
            (std::vector<std::string>{
                "2024-01-30", "2024-02-29", "2024-03-30", "2024-04-30", "2024-05-30"}));
  EXPECT_EQ(c->layers[0].time.defaultValue, "2024-05-30");
  EXPECT_EQ(c->layers[1].time.values,
            (std::vector<std::string>{
                "2024-03-01T00:00:00Z", "2024-03-01T06:00:00Z", "2024-03-01T12:00:00Z"}));
  EXPECT_EQ(c->layers[1].time.defaultValue, "2024-03-01T06:00:00Z");
  EXPECT_EQ(c->layers[2].time.values,
            (std::vector<std::string>{
                "2024-01-01T00:00:00Z", "2024-01-01T12:00:00Z", "2024-01-02T00:00:00Z"}));
}

TEST(ConfigYaml, RelativePathsResolveAgainstTheFilesFolder) {
  const test::TempDir dir("config-paths");
  const fs::path conf = dir.path() / "etc" / "tellus.yaml";
  fs::create_directories(dir.path() / "etc" / "images");
  fs::create_directories(dir.path() / "shared");
  fs::copy_file(kData / "bmng_2048x1024.jpg", dir.path() / "etc" / "images" / "world.jpg");
  fs::copy_file(kData / "etopo20_int16.tif", dir.path() / "shared" / "heights.tif");
  writeFile(conf, R"(cache:
  root: ../var/cache
upstreams:
  - name: img
    type: local
    path: images/world.jpg
layers:
  - name: world
    upstream: img
    format: image/jpeg
    grid: {levels: 1}
)");
  const auto c = loadConfig(conf);
  ASSERT_TRUE(c) << c.error().toString();
  EXPECT_EQ(c->upstreams[0].path, dir.path() / "etc" / "images" / "world.jpg");
  EXPECT_EQ(c->cache.root, dir.path() / "var" / "cache");

  // data_dir moves the base of local paths (not of the cache root).
  writeFile(conf, R"(data_dir: ../shared
cache: {root: cache}
upstreams:
  - {name: h, type: local, path: heights.tif}
layers:
  - {name: h, upstream: h, format: application/bil16, grid: {levels: 1, level_zero_delta: 20, tile_size: 150}}
)");
  const auto d = loadConfig(conf);
  ASSERT_TRUE(d) << d.error().toString();
  EXPECT_EQ(d->upstreams[0].path, dir.path() / "shared" / "heights.tif");
  EXPECT_EQ(d->cache.root, dir.path() / "etc" / "cache");

  // An absolute path stays as it is; a missing file is an error at its line.
  writeFile(conf, R"(upstreams:
  - name: img
    type: local
    path: images/nothing.jpg
layers:
  - {name: world, upstream: img, format: image/jpeg, grid: {levels: 1}}
)");
  const auto e = loadConfig(conf);
  ASSERT_FALSE(e);
  EXPECT_EQ(e.error().file, conf.string());
  EXPECT_EQ(e.error().line, 4);
  EXPECT_EQ(e.error().key, "upstreams[0].path");
  EXPECT_NE(e.error().message.find("does not exist"), std::string::npos);
}

// ---- errors: file, line, key --------------------------------------------------------------------

TEST(ConfigYaml, UnknownKeySuggestsTheClosest) {
  std::string yaml(kMinimal);
  yaml += "      tiel_size: 256\n";
  const ConfigError e = errorOf(yaml);
  EXPECT_EQ(e.line, 11);
  EXPECT_EQ(e.column, 7);
  EXPECT_EQ(e.key, "layers[0].grid.tiel_size");
  EXPECT_EQ(e.message, "unknown key 'tiel_size' (did you mean 'tile_size'?)");
  EXPECT_EQ(e.toString(),
            "test.yaml:11:7: layers[0].grid.tiel_size: unknown key 'tiel_size' (did you mean "
            "'tile_size'?)");

  const ConfigError camel = errorOf(std::string(kMinimal) + "    upstreamLayer: x\n");
  EXPECT_NE(camel.message.find("did you mean 'upstream_layer'"), std::string::npos);
  const ConfigError none = errorOf(std::string(kMinimal) + "colour: blue\n");
  EXPECT_EQ(none.key, "colour");
  EXPECT_EQ(none.line, 11);
  EXPECT_NE(none.message.find("expected one of: server, cache"), std::string::npos);
}

TEST(ConfigYaml, WrongTypes) {
  const ConfigError levels = errorOf(R"(upstreams:
  - {name: up, type: wms, url: "http://example.org/"}
layers:
  - name: a
    upstream: up
    format: image/jpeg
    grid:
      levels: [1, 2]
)");
  EXPECT_EQ(levels.line, 8);
  EXPECT_EQ(levels.key, "layers[0].grid.levels");
  EXPECT_EQ(levels.message, "expected a whole number, got a list");

  const ConfigError half = errorOf(swap(kMinimal, "levels: 3", "levels: 2.5"));
  EXPECT_EQ(half.key, "layers[0].grid.levels");
  EXPECT_EQ(half.message, "expected a whole number, got '2.5'");

  const ConfigError grid = errorOf(swap(kMinimal, "grid:\n      levels: 3", "grid: 5"));
  EXPECT_EQ(grid.key, "layers[0].grid");
  EXPECT_EQ(grid.line, 9);
  EXPECT_NE(grid.message.find("expected a mapping"), std::string::npos);

  const ConfigError layers = errorOf("upstreams: []\nlayers: {a: 1}\n");
  EXPECT_EQ(layers.key, "layers");
  EXPECT_EQ(layers.line, 2);
  EXPECT_EQ(layers.message, "expected a list, got a mapping");

  const ConfigError flag = errorOf("server: {offline: maybe}\n" + std::string(kMinimal));
  EXPECT_EQ(flag.key, "server.offline");
  EXPECT_EQ(flag.line, 1);
  EXPECT_EQ(flag.message, "expected true or false, got 'maybe'");

  const ConfigError title = errorOf(std::string(kMinimal) + "    title: {a: b}\n");
  EXPECT_EQ(title.key, "layers[0].title");
  EXPECT_EQ(title.message, "expected a string, got a mapping");

  const ConfigError type = errorOf(R"(upstreams:
  - name: up
    type: tms
)");
  EXPECT_EQ(type.key, "upstreams[0].type");
  EXPECT_EQ(type.line, 3);
  EXPECT_EQ(type.message, "'tms' is not one of local, wms, worldwind, wmts");

  const ConfigError earth = errorOf("renderer:\n  earth: flat\n" + std::string(kMinimal));
  EXPECT_EQ(earth.key, "renderer.earth");
  EXPECT_EQ(earth.line, 2);
  EXPECT_EQ(earth.message, "'flat' is not one of wgs84, sphere");

  const ConfigError method =
      errorOf("renderer:\n  dome: {method: sphere}\n" + std::string(kMinimal));
  EXPECT_EQ(method.key, "renderer.dome.method");
  EXPECT_EQ(method.line, 2);
  EXPECT_EQ(method.message, "'sphere' is not one of direct, cube");

  const ConfigError sunlight = errorOf("renderer: {sunlight: maybe}\n" + std::string(kMinimal));
  EXPECT_EQ(sunlight.key, "renderer.sunlight");
  const ConfigError night =
      errorOf("renderer:\n  layers: [{layer: a, night: 2}]\n" + std::string(kMinimal));
  EXPECT_EQ(night.key, "renderer.layers[0].night");
  const ConfigError air =
      errorOf("renderer:\n  atmosphere: {ozone_absorption: [1, 2]}\n" + std::string(kMinimal));
  EXPECT_EQ(air.key, "renderer.atmosphere.ozone_absorption");
  EXPECT_EQ(air.message, "expected 3 numbers [r, g, b], got 2");
  const ConfigError airKey =
      errorOf("renderer:\n  atmosphere: {haze: 1}\n" + std::string(kMinimal));
  EXPECT_EQ(airKey.key, "renderer.atmosphere.haze");
  const ConfigError airResolution =
      errorOf("renderer:\n  atmosphere: {resolution: eighth}\n" + std::string(kMinimal));
  EXPECT_EQ(airResolution.key, "renderer.atmosphere.resolution");
  EXPECT_EQ(airResolution.message, "must be full, half or quarter, got 'eighth'");

  const ConfigError geoid = errorOf("renderer: {geoid: egm96}\n" + std::string(kMinimal));
  EXPECT_EQ(geoid.key, "renderer.geoid");
  EXPECT_EQ(geoid.message, "expected true or false, got 'egm96'");

  const ConfigError stars =
      errorOf("renderer:\n  stars: {enabled: true, twinkle: 1}\n" + std::string(kMinimal));
  EXPECT_EQ(stars.key, "renderer.stars.twinkle");
  EXPECT_EQ(stars.line, 2);
}

TEST(ConfigYaml, BadDurationAndSize) {
  const ConfigError d = errorOf(R"(upstreams:
  - name: up
    type: wms
    url: http://example.org/wms
    timeout: 10 parsecs
)");
  EXPECT_EQ(d.line, 5);
  EXPECT_EQ(d.column, 14);
  EXPECT_EQ(d.key, "upstreams[0].timeout");
  EXPECT_NE(d.message.find("'10 parsecs' is not a duration"), std::string::npos);

  const ConfigError bare = errorOf("server: {limits: {request_timeout: 30}}\n");
  EXPECT_EQ(bare.key, "server.limits.request_timeout");
  EXPECT_NE(bare.message.find("not a duration"), std::string::npos);

  const ConfigError s = errorOf("cache:\n  size_limit: lots\n" + std::string(kMinimal));
  EXPECT_EQ(s.line, 2);
  EXPECT_EQ(s.key, "cache.size_limit");
  EXPECT_NE(s.message.find("'lots' is not a size"), std::string::npos);

  const ConfigError age = errorOf(std::string(kMinimal) + "    cache: {max_age: 1500ms}\n");
  EXPECT_EQ(age.key, "layers[0].cache.max_age");
  EXPECT_NE(age.message.find("whole seconds"), std::string::npos);

  const ConfigError opacity = errorOf(std::string(kMinimal) + "    opacity: 1.5\n");
  EXPECT_EQ(opacity.key, "layers[0].opacity");
  EXPECT_NE(opacity.message.find("from 0 to 1"), std::string::npos);
  EXPECT_EQ(errorOf(std::string(kMinimal) + "    opacity: .nan\n").key, "layers[0].opacity");
  EXPECT_EQ(errorOf("server: {limits: {max_tiles_per_map: 0}}\n" + std::string(kMinimal)).key,
            "server.limits.max_tiles_per_map");
  EXPECT_EQ(errorOf("server: {jpeg_quality: 0}\n" + std::string(kMinimal)).key,
            "server.jpeg_quality");
  EXPECT_EQ(errorOf("server: {jpeg_quality: 101}\n" + std::string(kMinimal)).key,
            "server.jpeg_quality");
}

TEST(ConfigYaml, MissingRequiredKeys) {
  const ConfigError name = errorOf(R"(upstreams:
  - name: up
    type: wms
    url: http://example.org/wms
layers:
  - upstream: up
    format: image/jpeg
    grid: {levels: 1}
)");
  EXPECT_EQ(name.line, 6);
  EXPECT_EQ(name.key, "layers[0].name");
  EXPECT_EQ(name.message, "required key 'name' is missing");

  const ConfigError empty = errorOf(R"(upstreams:
  - name:
    type: wms
)");
  EXPECT_EQ(empty.line, 2);
  EXPECT_EQ(empty.key, "upstreams[0].name");
  EXPECT_EQ(empty.message, "'name' needs a value");

  const ConfigError url = errorOf("upstreams:\n  - {name: up, type: wms}\n");
  EXPECT_EQ(url.key, "upstreams[0].url");
  EXPECT_EQ(url.line, 2);

  const ConfigError levels = errorOf(swap(kMinimal, "levels: 3", "tile_size: 256"));
  EXPECT_EQ(levels.key, "layers[0].grid.levels");
  EXPECT_EQ(levels.line, 10);

  const ConfigError layers = errorOf("upstreams: []\n");
  EXPECT_EQ(layers.key, "layers");
  EXPECT_EQ(layers.message, "required key 'layers' is missing");
  const ConfigError noLayers = errorOf("upstreams: []\nlayers: []\n");
  EXPECT_EQ(noLayers.key, "layers");
  EXPECT_EQ(noLayers.line, 2);
}

TEST(ConfigYaml, DuplicateNamesAndKeys) {
  const ConfigError layer = errorOf(std::string(kMinimal) + R"(  - name: a
    upstream: up
    format: image/png
    grid: {levels: 1}
)");
  EXPECT_EQ(layer.line, 11);
  EXPECT_EQ(layer.column, 11);
  EXPECT_EQ(layer.key, "layers[1].name");
  EXPECT_EQ(layer.message, "layer 'a': the name is used twice");

  const ConfigError upstream = errorOf(R"(upstreams:
  - {name: up, type: wms, url: "http://a.example/"}
  - {name: up, type: wms, url: "http://b.example/"}
layers:
  - {name: a, upstream: up, format: image/jpeg, grid: {levels: 1}}
)");
  EXPECT_EQ(upstream.line, 3);
  EXPECT_EQ(upstream.key, "upstreams[1].name");

  const ConfigError key = errorOf(std::string(kMinimal) + "    format: image/png\n");
  EXPECT_EQ(key.line, 11);
  EXPECT_EQ(key.key, "layers[0].format");
  EXPECT_EQ(key.message, "key 'format' is given twice (first on line 8)");

  const ConfigError header = errorOf(R"(upstreams:
  - name: up
    type: wms
    url: http://example.org/wms
    headers:
      User-Agent: a
      user-agent: b
)");
  EXPECT_EQ(header.line, 7);
  EXPECT_EQ(header.key, "upstreams[0].headers.user-agent");
}

TEST(ConfigYaml, UnknownUpstreamReference) {
  std::string yaml(kMinimal);
  yaml.replace(yaml.find("upstream: up"), 12, "upstream: upp");
  const ConfigError e = errorOf(yaml);
  EXPECT_EQ(e.line, 7);
  EXPECT_EQ(e.column, 15);
  EXPECT_EQ(e.key, "layers[0].upstream");
  EXPECT_EQ(e.message, "layer 'a': no upstream named 'upp' (upstreams: up)");
}

TEST(ConfigYaml, BadGrids) {
  const auto withGrid = [](std::string_view grid) {
    std::string yaml(kMinimal);
    yaml.replace(yaml.find("      levels: 3\n"), 16, grid);
    return yaml;
  };
  const ConfigError delta = errorOf(withGrid("      levels: 3\n      level_zero_delta: 37\n"));
  EXPECT_EQ(delta.line, 11);
  EXPECT_EQ(delta.key, "layers[0].grid.level_zero_delta");
  EXPECT_NE(delta.message.find("level_zero_delta must divide 180"), std::string::npos);

  const ConfigError sector =
      errorOf(withGrid("      levels: 3\n      sector: [-190, -90, 180, 90]\n"));
  EXPECT_EQ(sector.line, 11);
  EXPECT_EQ(sector.key, "layers[0].grid.sector");
  EXPECT_NE(sector.message.find("sector west must be finite and in [-180, 180]"),
            std::string::npos);

  const ConfigError flipped = errorOf(withGrid("      levels: 3\n      sector: [0, 10, 20, 5]\n"));
  EXPECT_EQ(flipped.key, "layers[0].grid.sector");
  EXPECT_NE(flipped.message.find("must be <"), std::string::npos);

  const ConfigError nan =
      errorOf(withGrid("      levels: 3\n      sector: [-180, .nan, 180, 90]\n"));
  EXPECT_EQ(nan.line, 11);
  EXPECT_EQ(nan.column, 22);
  EXPECT_EQ(nan.key, "layers[0].grid.sector[1]");
  EXPECT_EQ(nan.message, "must be a finite number, got '.nan'");

  const ConfigError inf = errorOf(withGrid("      levels: 3\n      level_zero_delta: -.Inf\n"));
  EXPECT_EQ(inf.key, "layers[0].grid.level_zero_delta");
  EXPECT_EQ(inf.message, "must be a finite number, got '-.Inf'");

  const ConfigError three = errorOf(withGrid("      levels: 3\n      sector: [1, 2, 3]\n"));
  EXPECT_EQ(three.key, "layers[0].grid.sector");
  EXPECT_NE(three.message.find("expected 4 numbers"), std::string::npos);

  const ConfigError tile = errorOf(withGrid("      levels: 3\n      tile_size: 0\n"));
  EXPECT_EQ(tile.key, "layers[0].grid.tile_size");
  EXPECT_EQ(tile.line, 11);

  const ConfigError first = errorOf(withGrid("      levels: 3\n      first_level: 1\n"));
  EXPECT_EQ(first.key, "layers[0].grid.first_level");
  EXPECT_NE(first.message.find("worldwind upstreams only"), std::string::npos);
}

TEST(ConfigYaml, HugeLevelCounts) {
  const ConfigError huge = errorOf(swap(kMinimal, "levels: 3", "levels: 99999999999999999999"));
  EXPECT_EQ(huge.line, 10);
  EXPECT_EQ(huge.key, "layers[0].grid.levels");
  EXPECT_NE(huge.message.find("out of range"), std::string::npos);
  const ConfigError big = errorOf(swap(kMinimal, "levels: 3", "levels: 4000000000"));
  EXPECT_EQ(big.key, "layers[0].grid.levels");
  EXPECT_NE(big.message.find("out of range"), std::string::npos);
  const ConfigError deep = errorOf(swap(kMinimal, "levels: 3", "levels: 1000"));
  EXPECT_EQ(deep.line, 10);
  EXPECT_EQ(deep.key, "layers[0].grid.levels");
  EXPECT_NE(deep.message.find("levels must be in [1, 31], got 1000"), std::string::npos);
  const ConfigError zero = errorOf(swap(kMinimal, "levels: 3", "levels: 0"));
  EXPECT_EQ(zero.key, "layers[0].grid.levels");
}

TEST(ConfigYaml, EmptyAndNonMappingDocuments) {
  for (const char* text : {"", "\n\n", "# only a comment\n", "~\n", "---\n"}) {
    const ConfigError e = errorOf(text);
    EXPECT_EQ(e.key, "") << text;
    EXPECT_GE(e.line, 1) << text;
    EXPECT_NE(e.message.find("empty"), std::string::npos) << text;
  }
  const ConfigError list = errorOf("- a\n- b\n");
  EXPECT_EQ(list.line, 1);
  EXPECT_EQ(list.key, "");
  EXPECT_NE(list.message.find("the top level must be a mapping"), std::string::npos);
  EXPECT_NE(list.message.find("got a list"), std::string::npos);
  const ConfigError scalar = errorOf("hello\n");
  EXPECT_NE(scalar.message.find("got 'hello'"), std::string::npos);
  const ConfigError two = errorOf(std::string(kMinimal) + "---\nlayers: []\n");
  EXPECT_EQ(two.line, 12);
  EXPECT_NE(two.message.find("more than one YAML document"), std::string::npos);
}

TEST(ConfigYaml, SyntaxErrorsCarryYamlCppsLine) {
  const ConfigError tab = errorOf("upstreams:\n  - name: up\n\ttype: wms\n");
  EXPECT_EQ(tab.line, 3);
  EXPECT_NE(tab.message.find("YAML syntax"), std::string::npos);
  const ConfigError tab2 = errorOf("layers:\n\t- name: a\n");
  EXPECT_EQ(tab2.line, 2);
  const ConfigError flow = errorOf("upstreams: [1, 2\nlayers: []\n");
  EXPECT_EQ(flow.line, 2);
  EXPECT_NE(flow.message.find("YAML syntax"), std::string::npos);
  const ConfigError alias = errorOf("layers: *nope\n");
  EXPECT_EQ(alias.line, 1);
  EXPECT_NE(alias.message.find("anchor"), std::string::npos);
}

TEST(ConfigYaml, KeysThatDoNotApply) {
  const ConfigError path = errorOf(R"(upstreams:
  - name: up
    type: wms
    url: http://example.org/wms
    path: /tmp/x.jpg
)");
  EXPECT_EQ(path.line, 5);
  EXPECT_EQ(path.key, "upstreams[0].path");
  EXPECT_EQ(path.message, "'path' applies to local upstreams only");
  const ConfigError url = errorOf(R"(upstreams:
  - name: up
    type: local
    path: x.jpg
    url: http://example.org/
)");
  EXPECT_EQ(url.line, 5);
  EXPECT_EQ(url.key, "upstreams[0].url");
  const ConfigError meta = errorOf(R"(upstreams:
  - {name: ww, type: worldwind, url: "http://example.org/", meta_tiles: 4}
)");
  EXPECT_EQ(meta.key, "upstreams[0].meta_tiles");
  EXPECT_EQ(meta.message, "'meta_tiles' applies to wms upstreams only");
  const ConfigError version = errorOf(R"(upstreams:
  - {name: ww, type: worldwind, url: "http://example.org/", version: 1.3.0}
)");
  EXPECT_EQ(version.key, "upstreams[0].version");
  const ConfigError elevation = errorOf(std::string(kMinimal) + "    elevation: {scale: 2}\n");
  EXPECT_EQ(elevation.line, 11);
  EXPECT_EQ(elevation.key, "layers[0].elevation");
  EXPECT_NE(elevation.message.find("elevation layers only"), std::string::npos);
}

TEST(ConfigYaml, FormatsKindsAndEncodings) {
  const auto withFormat = [](std::string_view format, std::string_view extra = {}) {
    std::string yaml(kMinimal);
    yaml.replace(yaml.find("image/jpeg"), 10, format);
    return yaml + std::string(extra);
  };
  const ConfigError bmp = errorOf(withFormat("image/bmp"));
  EXPECT_EQ(bmp.key, "layers[0].format");
  EXPECT_EQ(bmp.line, 8);
  EXPECT_NE(bmp.message.find("is not one of image/jpeg"), std::string::npos);
  const ConfigError bilImagery = errorOf(withFormat("application/bil16", "    kind: imagery\n"));
  EXPECT_EQ(bilImagery.key, "layers[0].kind");
  EXPECT_EQ(bilImagery.line, 11);
  const ConfigError jpegHeights = errorOf(withFormat("image/jpeg", "    kind: elevation\n"));
  EXPECT_EQ(jpegHeights.key, "layers[0].format");
  EXPECT_NE(jpegHeights.message.find("lossless"), std::string::npos);
  const ConfigError encoding =
      errorOf(withFormat("application/bil16", "    elevation: {encoding: png16}\n"));
  EXPECT_EQ(encoding.key, "layers[0].elevation.encoding");
  EXPECT_EQ(encoding.line, 11);
  const ConfigError scale = errorOf(withFormat("application/bil16", "    elevation: {scale: 0}\n"));
  EXPECT_EQ(scale.key, "layers[0].elevation.scale");
  const ConfigError kind = errorOf(withFormat("image/png", "    kind: terrain\n"));
  EXPECT_EQ(kind.key, "layers[0].kind");
  EXPECT_EQ(kind.message, "'terrain' is not one of imagery, elevation, values");
}

TEST(ConfigYaml, BadUrlsAndAddresses) {
  const auto withUrl = [](std::string_view url) {
    std::string yaml(kMinimal);
    yaml.replace(yaml.find("http://example.org/wms"), 22, url);
    return yaml;
  };
  for (const char* url : {"ftp://example.org/wms",
                          "http://",
                          "http:///wms",
                          "\"http://exa mple.org/\"",
                          "example.org/wms",
                          "http://example.org:99999/",
                          "http://user:secret@example.org/",
                          "http://example.org/wms#top"}) {
    const ConfigError e = errorOf(withUrl(url));
    EXPECT_EQ(e.key, "upstreams[0].url") << url;
    EXPECT_EQ(e.line, 4) << url;
  }
  EXPECT_TRUE(parse(withUrl("\"HTTPS://[::1]:8443/wms?map=/x/y.map&a=b\"")));

  for (const char* listen :
       {"localhost", "127.0.0.1:", ":8080", "::1:8080", "[::1]", "host:65536", "host:-1"}) {
    const ConfigError e =
        errorOf("server:\n  listen: \"" + std::string(listen) + "\"\n" + std::string(kMinimal));
    EXPECT_EQ(e.key, "server.listen") << listen;
    EXPECT_EQ(e.line, 2) << listen;
  }
  const auto any = parse("server: {listen: 0.0.0.0:0}\n" + std::string(kMinimal));
  ASSERT_TRUE(any) << any.error().toString();
  EXPECT_EQ(any->server.listenPort, 0);

  const ConfigError pub =
      errorOf("server: {public_url: tiles.example.org}\n" + std::string(kMinimal));
  EXPECT_EQ(pub.key, "server.public_url");
  const ConfigError header = errorOf(R"(upstreams:
  - name: up
    type: wms
    url: http://example.org/wms
    headers: {X-Evil: "a\r\nHost: b"}
layers:
  - {name: a, upstream: up, format: image/jpeg, grid: {levels: 1}}
)");
  EXPECT_EQ(header.key, "upstreams[0].headers.X-Evil");
  EXPECT_EQ(header.line, 5);
  const ConfigError headerName = errorOf(R"(upstreams:
  - name: up
    type: wms
    url: http://example.org/wms
    headers: {"Bad Name": x}
layers:
  - {name: a, upstream: up, format: image/jpeg, grid: {levels: 1}}
)");
  EXPECT_EQ(headerName.key, "upstreams[0].headers");
}

TEST(ConfigYaml, TimeErrors) {
  const auto withTime = [](std::string_view time) {
    return std::string(kMinimal) + "    time:\n" + std::string(time);
  };
  const ConfigError both =
      errorOf(withTime("      values: [2024-01-01]\n      period: 2024-01-01/2024-02-01/P1D\n"));
  EXPECT_EQ(both.line, 13);
  EXPECT_EQ(both.key, "layers[0].time.period");
  const ConfigError neither = errorOf(withTime("      default: 2024-01-01\n"));
  EXPECT_EQ(neither.key, "layers[0].time");
  const ConfigError period = errorOf(withTime("      period: 2024-01-01/2023-01-01/P1D\n"));
  EXPECT_EQ(period.line, 12);
  EXPECT_EQ(period.key, "layers[0].time.period");
  EXPECT_NE(period.message.find("ends before it starts"), std::string::npos);
  for (const char* bad : {"2024-01-01/2024-02-01",
                          "2024-01-01/2024-02-01/1D",
                          "2024-02-30/2024-03-01/P1D",
                          "2024-01-01/2024-02-01/P",
                          "2024-01-01/2024-02-01/PT",
                          "2024-01-01/2024-02-01/P0D",
                          "2024-01-01/2024-02-01/P1H",
                          "2024-01-01T25:00Z/2024-02-01/P1D"}) {
    const ConfigError e = errorOf(withTime("      period: \"" + std::string(bad) + "\"\n"));
    EXPECT_EQ(e.key, "layers[0].time.period") << bad;
  }
  const ConfigError notListed =
      errorOf(withTime("      values: [2024-01-01, 2024-01-02]\n      default: 2024-01-03\n"));
  EXPECT_EQ(notListed.key, "layers[0].time.default");
  EXPECT_EQ(notListed.line, 13);
  const ConfigError twice = errorOf(withTime("      values: [2024-01-01, 2024-01-01]\n"));
  EXPECT_EQ(twice.key, "layers[0].time.values");
  const ConfigError comma = errorOf(withTime("      values: [\"a,b\"]\n"));
  EXPECT_EQ(comma.key, "layers[0].time.values");
  const ConfigError outside =
      errorOf(withTime("      period: 2024-01-01/2024-02-01/P1D\n      default: 2025-01-01\n"));
  EXPECT_EQ(outside.key, "layers[0].time.default");
}

TEST(ConfigYaml, LoadConfigReportsUnreadableFiles) {
  const auto missing = loadConfig("/nonexistent/tellus.yaml");
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().file, "/nonexistent/tellus.yaml");
  EXPECT_EQ(missing.error().line, 0);
  EXPECT_NE(missing.error().message.find("no such file"), std::string::npos);
  const test::TempDir dir("config-dir");
  const auto directory = loadConfig(dir.path());
  ASSERT_FALSE(directory);
  EXPECT_NE(directory.error().message.find("directory"), std::string::npos);
}

// ---- renderer.layers (issue #7) -----------------------------------------------------------------

namespace {

constexpr std::string_view kLayered = R"(upstreams:
  - name: up
    type: wms
    url: http://example.org/wms
layers:
  - name: bm
    upstream: up
    format: image/jpeg
    grid: {levels: 3}
  - name: alps
    upstream: up
    format: image/jpeg
    grid: {levels: 8, sector: [4.5, 43.2, 16.2, 48.6]}
  - name: sst
    upstream: up
    format: image/png
    opacity: 0.7
    grid: {levels: 2}
    time: {values: [2020-01-01, 2020-02-01]}
  - name: ww
    upstream: up
    format: image/png
    grid: {levels: 2, level_zero_delta: 20, tile_size: 150}
  - name: dem
    upstream: up
    format: application/bil16
    grid: {levels: 4, level_zero_delta: 20, tile_size: 150}
  - name: dem-alps
    upstream: up
    format: application/bil16
    grid: {levels: 9, level_zero_delta: 20, tile_size: 150, sector: [4, 43, 17, 49]}
renderer:
  terrain:
    layer: dem
    regional: [dem-alps]
  layers:
    - layer: bm
      regional: [alps]
    - layer: sst
      time: 2020-02-01
      max_level: 1
    - layer: sst
      opacity: 0.25
      visible: false
      night: true
)";

} // namespace

TEST(ConfigYaml, RendererLayersAreRead) {
  const auto c = parse(kLayered);
  ASSERT_TRUE(c) << c.error().toString();
  const auto& l = c->renderer.layers;
  ASSERT_EQ(l.size(), 3u);
  EXPECT_EQ(l[0].layer, "bm");
  EXPECT_EQ(l[0].regional, std::vector<std::string>{"alps"});
  EXPECT_FALSE(l[0].opacity.has_value());
  EXPECT_EQ(l[1].layer, "sst");
  EXPECT_EQ(l[1].time, "2020-02-01");
  EXPECT_EQ(l[1].maxLevel, 1);
  EXPECT_TRUE(l[1].visible);
  EXPECT_EQ(l[2].opacity, 0.25);
  EXPECT_TRUE(l[2].night);
  EXPECT_FALSE(l[1].night);
  EXPECT_FALSE(l[2].visible);
  EXPECT_EQ(l[2].maxLevel, -1);
  EXPECT_EQ(c->renderer.terrain.regional, std::vector<std::string>{"dem-alps"});
}

TEST(ConfigYaml, RendererLayersAreValidated) {
  const auto bad = [](std::string_view from, std::string_view to) {
    return errorOf(swap(kLayered, from, to)).message;
  };
  EXPECT_NE(bad("    - layer: bm\n", "    - layer: bm\n      opacity: 0.5\n").find("opaque base"),
            std::string::npos);
  EXPECT_NE(bad("    - layer: sst\n      time", "    - layer: ww\n      time").find("grid"),
            std::string::npos);
  EXPECT_NE(bad("regional: [alps]", "regional: [ww]").find("another grid"), std::string::npos);
  EXPECT_NE(bad("regional: [alps]", "regional: [dem]").find("not an imagery layer"),
            std::string::npos);
  EXPECT_NE(bad("regional: [dem-alps]", "regional: [alps]").find("not an elevation layer"),
            std::string::npos);
  EXPECT_NE(bad("time: 2020-02-01", "time: 2020-03-01").find("not a TIME value"),
            std::string::npos);
  EXPECT_NE(bad("opacity: 0.25", "opacity: 1.5").find("[0, 1]"), std::string::npos);
  EXPECT_NE(bad("    - layer: bm\n", "    - layer: dem\n").find("not an imagery layer"),
            std::string::npos);
  EXPECT_NE(bad("      max_level: 1", "      max_level: -3").find("[0, 40]"), std::string::npos);
  EXPECT_NE(bad("      max_level: 1", "      depth: 1").find("depth"), std::string::npos);
}

// Issue 21: which redirects of an upstream are followed, and the per-client fetch budget.
TEST(ConfigYaml, UpstreamRedirectsAndTheClientFetchBudget) {
  const auto defaults = parse(kMinimal);
  ASSERT_TRUE(defaults) << defaults.error().toString();
  EXPECT_EQ(defaults->upstreams.at(0).redirects, RedirectPolicy::SameOrigin);
  EXPECT_EQ(defaults->server.limits.fetchesPerClientPerMinute, 600.0);
  const std::string url = "    url: http://example.org/wms\n";
  for (const auto& [text, want] : {std::pair{"same-origin", RedirectPolicy::SameOrigin},
                                   std::pair{"any", RedirectPolicy::Any},
                                   std::pair{"none", RedirectPolicy::None}}) {
    const auto c = parse(swap(kMinimal, url, url + "    redirects: " + text + "\n"));
    ASSERT_TRUE(c) << c.error().toString();
    EXPECT_EQ(c->upstreams.at(0).redirects, want) << text;
  }
  const ConfigError bad = errorOf(swap(kMinimal, url, url + "    redirects: elsewhere\n"));
  EXPECT_EQ(bad.line, 5);
  EXPECT_EQ(bad.column, 16);
  EXPECT_EQ(bad.key, "upstreams[0].redirects");
  EXPECT_EQ(bad.message, "'elsewhere' is not one of same-origin, any, none");
  const ConfigError local = errorOf(R"(upstreams:
  - name: up
    type: local
    path: /x.jpg
    redirects: any
layers: []
)");
  EXPECT_EQ(local.line, 5);
  EXPECT_EQ(local.key, "upstreams[0].redirects");
  EXPECT_EQ(local.message, "'redirects' applies to wms, worldwind and wmts upstreams only");

  const auto budget =
      parse("server: {limits: {fetches_per_client_per_minute: 30}}\n" + std::string(kMinimal));
  ASSERT_TRUE(budget) << budget.error().toString();
  EXPECT_EQ(budget->server.limits.fetchesPerClientPerMinute, 30.0);
  const auto unlimited =
      parse("server: {limits: {fetches_per_client_per_minute: 0}}\n" + std::string(kMinimal));
  ASSERT_TRUE(unlimited) << unlimited.error().toString();
  const ConfigError negative =
      errorOf("server: {limits: {fetches_per_client_per_minute: -5}}\n" + std::string(kMinimal));
  EXPECT_EQ(negative.line, 1);
  EXPECT_EQ(negative.key, "server.limits.fetches_per_client_per_minute");
  EXPECT_EQ(negative.message, "server: must be a finite number >= 0");
  const ConfigError word =
      errorOf("server: {limits: {fetches_per_client_per_minute: many}}\n" + std::string(kMinimal));
  EXPECT_EQ(word.key, "server.limits.fetches_per_client_per_minute");
}

TEST(ConfigYaml, ServerCdnKeysAndTheirChecks) {
  const auto none = parse(std::string(kMinimal));
  ASSERT_TRUE(none) << none.error().toString();
  EXPECT_FALSE(none->server.cdn.sMaxAge);
  EXPECT_EQ(none->server.cdn.staleIfError, std::chrono::seconds(7 * 86400));
  EXPECT_EQ(none->server.cdn.keyHeader, "xkey");
  EXPECT_TRUE(none->server.cdn.purge.empty());
  const auto cdn =
      parse("server:\n  cdn:\n    s_maxage: 2h\n    stale_while_revalidate: 30s\n"
            "    stale_if_error: 0s\n    short_max_age: 5s\n"
            "    key_header: Surrogate-Key\n"
            "    purge: [\"http://127.0.0.1:6081/\", \"https://cdn.example/purge\"]\n" +
            std::string(kMinimal));
  ASSERT_TRUE(cdn) << cdn.error().toString();
  EXPECT_EQ(cdn->server.cdn.sMaxAge, std::chrono::seconds(7200));
  EXPECT_EQ(cdn->server.cdn.staleWhileRevalidate, std::chrono::seconds(30));
  EXPECT_EQ(cdn->server.cdn.staleIfError, std::chrono::seconds(0));
  EXPECT_EQ(cdn->server.cdn.shortMaxAge, std::chrono::seconds(5));
  EXPECT_EQ(cdn->server.cdn.keyHeader, "Surrogate-Key");
  ASSERT_EQ(cdn->server.cdn.purge.size(), 2u);
  EXPECT_EQ(cdn->server.cdn.purge[1], "https://cdn.example/purge");
  EXPECT_EQ(errorOf("server: {cdn: {s_maxage: 1500ms}}\n" + std::string(kMinimal)).key,
            "server.cdn.s_maxage");
  EXPECT_EQ(errorOf("server: {cdn: {purge: [ftp://x/]}}\n" + std::string(kMinimal)).key,
            "server.cdn.purge[0]");
  EXPECT_EQ(errorOf("server: {cdn: {key_header: \"a b\"}}\n" + std::string(kMinimal)).key,
            "server.cdn.key_header");
  EXPECT_EQ(errorOf("server: {cdn: {purge_all: true}}\n" + std::string(kMinimal)).key,
            "server.cdn.purge_all");
}

TEST(ConfigYaml, WmtsUpstreamsAndTheirKeys) {
  const auto c = parse(R"(upstreams:
  - name: gibs
    type: wmts
    url: https://gibs.example/wmts/epsg4326/best/wmts.cgi
    encoding: kvp
    retries: 1
layers:
  - name: modis
    upstream: gibs
    upstream_layer: MODIS_Terra_CorrectedReflectance_TrueColor
    tile_matrix_set: 250m
    format: image/jpeg
    grid: {levels: 6}
)");
  ASSERT_TRUE(c) << c.error().toString();
  EXPECT_EQ(c->upstreams[0].type, UpstreamConfig::Type::Wmts);
  EXPECT_EQ(c->upstreams[0].encoding, UpstreamConfig::Encoding::Kvp);
  EXPECT_EQ(c->upstreams[0].retries, 1);
  EXPECT_EQ(c->layers[0].tileMatrixSet, "250m");

  const ConfigError encoding = errorOf(R"(upstreams:
  - {name: w, type: wmts, url: "http://example.org/", encoding: soap}
)");
  EXPECT_EQ(encoding.key, "upstreams[0].encoding");
  EXPECT_EQ(encoding.message, "'soap' is not one of auto, rest, kvp");
  const ConfigError onWms = errorOf(R"(upstreams:
  - {name: w, type: wms, url: "http://example.org/", encoding: rest}
)");
  EXPECT_EQ(onWms.key, "upstreams[0].encoding");
  EXPECT_EQ(onWms.message, "'encoding' applies to wmts upstreams only");
  const ConfigError version = errorOf(R"(upstreams:
  - {name: w, type: wmts, url: "http://example.org/", version: 1.3.0}
)");
  EXPECT_EQ(version.key, "upstreams[0].version");
  const ConfigError noUrl = errorOf(R"(upstreams:
  - {name: w, type: wmts}
)");
  EXPECT_EQ(noUrl.key, "upstreams[0].url");
  const ConfigError set = errorOf(std::string(kMinimal) + "    tile_matrix_set: 250m\n");
  EXPECT_EQ(set.key, "layers[0].tile_matrix_set");
  EXPECT_NE(set.message.find("wmts upstreams only"), std::string::npos) << set.message;
}

TEST(ConfigYaml, CacheStoreInS3) {
  const auto c =
      parse("cache:\n  store: s3://tiles/prod\n  s3: {endpoint: 'http://127.0.0.1:9000/', "
            "region: eu-west-1, credentials_file: creds}\n" +
            std::string(kMinimal));
  ASSERT_TRUE(c) << c.error().toString();
  EXPECT_EQ(c->cache.store, "s3://tiles/prod");
  EXPECT_EQ(c->cache.s3.endpoint, "http://127.0.0.1:9000");
  EXPECT_EQ(c->cache.s3.region, "eu-west-1");
  EXPECT_EQ(c->cache.s3.credentialsFile, fs::path("/base/creds"));
  EXPECT_TRUE(c->cache.s3.localTier);
  EXPECT_EQ(errorOf("cache: {store: 's3://b', size_limit: 1GiB, s3: {endpoint: 'http://h'}}\n" +
                    std::string(kMinimal))
                .key,
            "cache.size_limit");
  EXPECT_EQ(parse(std::string(kMinimal))->cache.store, ""); // the default: tiles under the root

  EXPECT_EQ(errorOf("cache: {store: 'file:///x'}\n" + std::string(kMinimal)).key, "cache.store");
  const ConfigError noEndpoint = errorOf("cache: {store: 's3://b'}\n" + std::string(kMinimal));
  EXPECT_EQ(noEndpoint.key, "cache.s3");
  EXPECT_NE(noEndpoint.message.find("endpoint"), std::string::npos);
  for (const char* bad : {"ftp://h", "http://h/path", "http://user:pw@h"}) {
    const ConfigError e = errorOf("cache: {store: 's3://b', s3: {endpoint: '" + std::string(bad) +
                                  "'}}\n" + std::string(kMinimal));
    EXPECT_EQ(e.key, "cache.s3.endpoint") << bad;
    EXPECT_EQ(e.message.find("pw@"), std::string::npos) << e.message; // no password echoed
  }
  EXPECT_EQ(errorOf("cache: {s3: {secret: x}}\n" + std::string(kMinimal)).key, "cache.s3.secret");
}

TEST(ConfigYaml, CacheS3LocalTierLimit) {
  const std::string store = "cache: {store: 's3://b', s3: {endpoint: 'http://h'";
  const auto c = parse(store + ", local_tier_limit: 20 GiB}}\n" + std::string(kMinimal));
  ASSERT_TRUE(c) << c.error().toString();
  EXPECT_EQ(c->cache.s3.localTierLimitBytes, 20ULL << 30);
  EXPECT_EQ(parse(store + "}}\n" + std::string(kMinimal))->cache.s3.localTierLimitBytes, 0U);

  const ConfigError bad = errorOf(store + ", local_tier_limit: lots}}\n" + std::string(kMinimal));
  EXPECT_EQ(bad.key, "cache.s3.local_tier_limit");
  EXPECT_NE(bad.message.find("'lots' is not a size"), std::string::npos) << bad.message;
  EXPECT_EQ(errorOf(store + ", local_tier_limit: -1GiB}}\n" + std::string(kMinimal)).key,
            "cache.s3.local_tier_limit");
  // Without a store there is no local tier to bound (cache.size_limit bounds such a cache).
  const ConfigError noStore =
      errorOf("cache: {s3: {local_tier_limit: 1GiB}}\n" + std::string(kMinimal));
  EXPECT_EQ(noStore.key, "cache.s3.local_tier_limit");
  EXPECT_NE(noStore.message.find("cache.size_limit"), std::string::npos) << noStore.message;
  const ConfigError noTier =
      errorOf(store + ", local_tier: false, local_tier_limit: 1GiB}}\n" + std::string(kMinimal));
  EXPECT_EQ(noTier.key, "cache.s3.local_tier_limit");
  EXPECT_NE(noTier.message.find("local_tier is false"), std::string::npos) << noTier.message;
  // size_limit stays refused with a store (it would evict from the shared bucket) and says what
  // bounds the local copies instead.
  const ConfigError shared = errorOf(store + "}, size_limit: 1GiB}\n" + std::string(kMinimal));
  EXPECT_EQ(shared.key, "cache.size_limit");
  EXPECT_NE(shared.message.find("local_tier_limit"), std::string::npos) << shared.message;
}
