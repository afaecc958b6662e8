#pragma once
/**
 * @file Config.hpp
 * @brief The typed configuration of tellus: the server, the cache, the upstreams and the layers,
 * read from YAML (docs/CONFIG.md is the reference of every key).
 *
 * A configuration comes from a YAML file (`loadConfig`), from YAML text (`parseConfig`) or from the
 * embedded default (`embeddedDefault`: config/examples/default.yaml compiled into the library,
 * which serves the bundled public-domain data: Blue Marble imagery and ETOPO 20' heights). Loading
 * never throws: a bad file gives a `ConfigError` that names the file, the line, the column and the
 * key.
 */

#include <tellus/cache/Dataset.hpp>
#include <tellus/values/ColourScale.hpp>
#include <tellus/values/ValueFormat.hpp>

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace tellus {

/** What a WMS client gets for a tile that is not cached while the proxy is offline. */
enum class OfflineResponse {
  Exception, ///< an OGC ServiceException
  Blank,     ///< a transparent / empty tile of the requested format
};

/** Protection of the HTTP server against misbehaving clients (YAML `server.limits`). */
struct ServerLimits {
  int maxConnections = 4096;                          ///< open client connections
  std::size_t maxHeaderBytes = 16384;                 ///< request line + headers
  std::size_t maxParamBytes = 2048;                   ///< one query parameter value
  std::int32_t maxWidth = 4096;                       ///< WMS WIDTH, pixels
  std::int32_t maxHeight = 4096;                      ///< WMS HEIGHT, pixels
  std::chrono::milliseconds requestTimeout{10'000};   ///< to receive a whole request
  std::chrono::milliseconds keepaliveTimeout{60'000}; ///< idle keep-alive; 0 = close after each
  double requestsPerSecond = 0.0;                     ///< per client address; 0 = unlimited
  /// Upstream fetches one client address may cause per minute (a minute's worth at once, then
  /// refilled evenly); past it 429 with Retry-After. 0 = unlimited.
  double fetchesPerClientPerMinute = 600.0;
  std::int64_t maxMapPixels = 4096LL * 4096LL; ///< WIDTH x HEIGHT of a composed GetMap
  std::int32_t maxTilesPerMap = 256;           ///< tiles one composed GetMap may read (all layers)
  /// Bytes of decoded tiles kept between composed maps (0: none).
  std::uint64_t decodedTileCache = 32ULL << 20;
};

/** YAML `server.cdn`: what shared HTTP caches in front of tellus are told, and where a purge
 * goes (docs/CONFIG.md, docs/design/cdn.md). Durations in whole seconds. */
struct CdnSettings {
  std::optional<std::chrono::seconds> sMaxAge;              ///< none: the layer's ttl, else max_age
  std::optional<std::chrono::seconds> staleWhileRevalidate; ///< none: s-maxage, at most 1 day
  std::chrono::seconds staleIfError{7 * 86400};
  std::chrono::seconds shortMaxAge{60}; ///< absent tiles, empty maps, stale tiles
  std::string keyHeader = "xkey";       ///< surrogate keys; "" = none
  std::vector<std::string> purge;       ///< http(s) URLs that take PURGE with xkey-purge
};

/** YAML `server`. */
struct ServerSettings {
  std::string listenHost = "127.0.0.1"; ///< IPv6 without brackets
  std::uint16_t listenPort = 8080;      ///< 0 = any free port
  std::string publicUrl;                ///< base URL for capabilities; "" = from the request
  std::string cors = "*";               ///< Access-Control-Allow-Origin; "" = no header
  bool exceptionsHttpStatus = false;    ///< WMS exceptions with 4xx/5xx instead of 200
  OfflineResponse offlineResponse = OfflineResponse::Exception;
  bool offline = false;          ///< start offline (the --offline flag sets it too)
  int threads = 0;               ///< event-loop threads; 0 = cores - 1 (at least 1)
  std::string logLevel = "info"; ///< error, warn, info or debug (events on stderr)
  std::string accessLog;         ///< "" = none, "-" = stdout, else a file appended to
  /** JPEG quality (1-100) of the maps tellus composes (GetMap boxes that are not one cached
   * tile); cached tiles are served as stored. MapProxy's `jpeg_quality`, MapCache's <quality>. */
  int jpegQuality = 90;
  ServerLimits limits;
  CdnSettings cdn;
};

/** YAML `renderer.earth`: the figure of the Earth the renderer places imagery on. */
enum class EarthShape {
  Wgs84,  ///< the WGS84 ellipsoid (tile latitudes are geodetic), the default
  Sphere, ///< a sphere of the mean radius: cheaper, misplaces imagery by up to ~21 km
};

/** YAML `renderer`: the planet renderer of `tellus view` and `tellus render` (the command line's
 * --threshold overrides lod_threshold). */
/** YAML `renderer.terrain` (issue #6): heights from an elevation layer under the imagery. */
struct TerrainSettings {
  bool enabled = true;       ///< false: the bare ellipsoid
  std::string layer;         ///< elevation layer; "" = the first one configured
  double exaggeration = 1.0; ///< heights are multiplied by this, (0, 100]
  double clearanceM = 2.0;   ///< the camera stays this far above the terrain, [0, 1e6]
  /** A node fetches heights only where the largest relief could move it by this many pixels,
   * [0, 100]; 0: everywhere (issue #8, "model only what a scene requires"). */
  double minReliefPx = 0.5;
  std::optional<std::array<double, 2>>
      sun; ///< [lat, lon] of the subsolar point: lighting; none = unlit
  /** Elevation layers used where they cover a node whole, the smallest winning (a detailed
   * regional DEM inside the global one); same grid as `layer`. */
  std::vector<std::string> regional;
};

/** One entry of YAML `renderer.layers` (issue #7): an imagery layer drawn by the renderer. The
 * first entry is the opaque base; the others are drawn over it in order. */
struct RenderLayerSettings {
  std::string layer; ///< a configured imagery layer
  /** Imagery layers drawn as part of this one where they cover a node whole: the smallest
   * covering dataset wins (a detailed regional dataset inside a global one; thesis 4.6.3). They
   * must share the layer's level-zero tile size and tile size. */
  std::vector<std::string> regional;
  std::optional<double> opacity; ///< overlays: [0, 1]; default the layer's own `opacity`
  bool visible = true;           ///< overlays: drawn at start
  int maxLevel = -1;             ///< the deepest level fetched and drawn; -1: the layer's own
  std::string time;              ///< a value of the layer's TIME dimension; "" = its default
  /** Overlays: a night layer (issue 23), shown on the dark side only, as light, blended across
   * the terminator by the sun's elevation (planet::LayerOptions::night). */
  bool night = false;
  /** Overlays that name a value layer (or an elevation layer shown as colours; issue 24): the
   * colour map and range drawn instead of the layer's own `values.colour_map` / `values.range`
   * ("" / nullopt: the layer's). */
  std::string colourMap;
  std::optional<std::array<double, 2>> range;
};

/** YAML `renderer.dome` (issue #7): the angular fisheye domemaster of `--dome`. */
struct DomeSettings {
  bool enabled = false;    ///< true: render and view draw the dome without --dome
  double fovDeg = 180.0;   ///< (0, 220]
  double tiltDeg = 0.0;    ///< the dome's axis turned up from the view direction, [-180, 180]
  double faceScale = 0.64; ///< cube face size / image size, [0.1, 4]
  /** `method`: direct (one pass through the fisheye map) or cube (faces, then a warp). */
  enum class Method { Direct, Cube };
  Method method = Method::Direct;
  /** `direct_max_error`: the direct method's largest estimated straight-edge error in pixels
   * before a frame is drawn with the cube method, [0, 1e9]. */
  double directMaxErrorPx = 0.5;
};

/** YAML `renderer.stars` (issue 23): the star background from the bundled catalogue
 * (data/stars-hip-6.5.txt in the data directory). */
struct StarsSettings {
  bool enabled = true;         ///< false (or --no-stars): no stars
  double magnitudeLimit = 6.5; ///< `magnitude_limit`: fainter stars (larger V) left out, [-2, 25]
  /** Multiplies every star's energy (1: Sirius peaks at 0.92 of a full pixel), [0, 100]. */
  double brightness = 1.0;
};

/** `renderer.atmosphere.resolution` (and `--atmosphere-resolution`): full 1, half 2, quarter 4;
 * nullopt for any other name. */
inline std::optional<int> atmosphereResolutionDivisor(std::string_view name) {
  if (name == "full") return 1;
  if (name == "half") return 2;
  if (name == "quarter") return 4;
  return std::nullopt;
}

/** YAML `renderer.atmosphere` (issue 23): the physically based sky and aerial perspective; the
 * physical parameters of planet/Atmosphere.hpp (defaults: the Earth, Bruneton 2017), SI units. */
struct AtmosphereSettings {
  bool enabled = true;   ///< on by default in the configuration (`--no-atmosphere`: off)
  double exposure = 2.5; ///< display = 1 - exp(-exposure x radiance), (0, 1e6]
  /** `resolution`: the sky and haze computed at full, half or quarter the width and height
   * (`--atmosphere-resolution`); 1 (the default), 2 or 4. */
  int resolutionDivisor = 1;
  double bottomRadius = 0.0;    ///< `bottom_radius` metres; 0: the body's equatorial radius
  double topAltitude = 60000.0; ///< `top_altitude` metres above the bottom, (0, 1e6]
  std::array<double, 3> rayleighScattering{5.802e-6, 13.558e-6, 33.1e-6}; ///< 1/m, R G B
  double rayleighScaleHeight = 8000.0;                                    ///< metres
  double mieScattering = 3.996e-6;                                        ///< 1/m
  double mieExtinction = 4.44e-6; ///< 1/m, >= mie_scattering
  double mieScaleHeight = 1200.0; ///< metres
  double mieG = 0.8;              ///< `mie_g`: the phase function's asymmetry, (-1, 1)
  std::array<double, 3> ozoneAbsorption{0.650e-6, 1.881e-6, 0.085e-6}; ///< 1/m at the peak
  double ozoneCentre = 25000.0;                                  ///< metres: the tent layer's peak
  double ozoneHalfWidth = 15000.0;                               ///< metres: the tent's half width
  double sunAngularRadius = 0.004675;                            ///< radians, (0, 0.1)
  std::array<double, 3> solarIrradiance{1.474, 1.8504, 1.91198}; ///< at the top, per channel
  std::array<double, 3> groundAlbedo{0.1, 0.1, 0.1};             ///< [0, 1]
  double minSunCosine = -0.2; ///< `min_sun_cosine`: below it the sky is black, (-1, 0)
};

/** The bodies every configuration knows (planet/Body.hpp builds them): the Earth (WGS84), the
 * Moon (a sphere of 1737.4 km), Mars (3396.19 by 3376.2 km). */
inline constexpr std::array<std::string_view, 3> kBuiltinBodies{"earth", "moon", "mars"};

/** One entry of YAML `bodies` (issue 26): a body beside the built-in ones (docs/design/bodies.md).
 * Angles in degrees, rates per Julian century (pole) and per day (prime meridian), as the IAU
 * WGCCRE report gives them. */
struct BodyConfig {
  std::string name;                             ///< [A-Za-z0-9_.-]+, not a built-in body's
  std::array<double, 3> radii{0.0, 0.0, 0.0};   ///< a >= b (equatorial), c (polar), metres
  double poleRa = 0.0;                          ///< `rotation.pole_ra`
  double poleRaRate = 0.0;                      ///< `rotation.pole_ra_rate`
  double poleDec = 90.0;                        ///< `rotation.pole_dec`
  double poleDecRate = 0.0;                     ///< `rotation.pole_dec_rate`
  double primeMeridian = 0.0;                   ///< `rotation.prime_meridian`
  double rotationRate = 0.0;                    ///< `rotation.rate` (degrees a day)
  std::optional<AtmosphereSettings> atmosphere; ///< `atmosphere: none` (the default): nullopt
  int iauCode = 0;                              ///< `iau_code`: its IAU planetary CRS code; 0 none
  double reliefBound = 11000.0;                 ///< `relief_bound`: largest |height|, metres
};

struct RendererSettings {
  /** YAML `renderer.body`: the body the renderer shows (a built-in or a configured one); the
   * renderer draws only the layers on it (LayerConfig::dataset.body). --body overrides it. */
  std::string body = "earth";
  /** YAML `renderer.bodies`: the other bodies the scene shows beside the body orbited, each placed
   * by the ephemeris at the scene's time (issue 26, docs/design/bodies.md "Several bodies"):
   * earth, moon or mars (the bodies with an ephemeris); the orbited body may be listed (skipped).
   * Empty: one body. */
  std::vector<std::string> bodies;
  /** YAML `renderer.overview`: a layer of the base imagery's whole globe on a coarser grid, the
   * global texture and what whole-globe views draw (issue 29); "" none. */
  std::string overview;
  double lodThreshold = 1.0;                  ///< texel-to-pixel threshold, 0.05 - 64
  int meshSize = 33;                          ///< vertices along a node's edge, 2^n + 1 in [3, 257]
  double fovDeg = 45.0;                       ///< vertical field of view, (1, 170)
  std::uint64_t textureBudget = 768ULL << 20; ///< GPU bytes of node textures (the LRU's budget)
  std::uint64_t uploadPerFrame = 8ULL << 20;  ///< texture bytes uploaded a frame (banded)
  int maxInFlight = 16;                       ///< tile requests out at once
  int maxSplitsPerFrame = 64;                 ///< nodes created a frame
  int decodeThreads = 2;                      ///< texture decoding workers
  TerrainSettings terrain;                    ///< YAML `renderer.terrain`
  /** YAML `renderer.layers`: the base then the overlays; empty = the first imagery layer alone
   * (or the command line's --layer and --overlay). */
  std::vector<RenderLayerSettings> layers;
  /** Overlay textures blended in one pass (0: as many as the GPU allows, up to 8); lower values
   * force extra passes, for comparisons (bench/layers.sh). */
  int overlaysPerPass = 0;
  DomeSettings dome;                    ///< YAML `renderer.dome`
  StarsSettings stars;                  ///< YAML `renderer.stars`
  AtmosphereSettings atmosphere;        ///< YAML `renderer.atmosphere`
  EarthShape earth = EarthShape::Wgs84; ///< wgs84 | sphere
  /** Heights of mean-sea-level datasets moved onto the ellipsoid with the EGM96 geoid (h = H + N,
   * the bundled data/egm96-30.pgm); false: taken as ellipsoid heights. Used by terrain. */
  bool geoid = true;
  /** YAML `renderer.time` (issue 23): the scene's time, an ISO 8601 UTC instant
   * ("2024-06-20T12:00:00Z", "2024-06-20") or "now"; "" = the command's default (view: now;
   * render: kDefaultRenderTime, so that renders are reproducible). --time overrides it. */
  std::string time;
  /** YAML `renderer.sunlight`: the globe lit by the sun of the scene's time (--no-sun: off). */
  bool sunlight = true;
  /** YAML `renderer.night`: the night layers (renderer.layers[i].night) shown (--no-night: off,
   * they are hidden). */
  bool night = true;
  /** No popping (issue 23): seconds over which an arriving texture fades in (0 = off), [0, 10]. */
  double fadeInS = 0.3;
  /** No popping (issue 23): geomorphing of node heights between levels (thesis 6.2.2). */
  bool geomorph = true;
  /** YAML `renderer.legend` (issue 24): the legends of visible value layers; nullopt: the
   * command's default (view: shown, render: not; --legend, --no-legend override). */
  std::optional<bool> legend;
};

/** YAML `cache`. */
struct CacheSettings {
  std::filesystem::path root;       ///< cache root (index.sqlite + the tile tree)
  std::uint64_t sizeLimitBytes = 0; ///< 0 = unlimited
  /// YAML `keep_unstored`: fetched tiles the cache could not store (a full disk, an unreachable
  /// store) kept in memory up to this many bytes (TileServiceOptions::keepUnstoredBytes); 0: none.
  std::uint64_t keepUnstoredBytes = 64u << 20;
  /// YAML `index` (issue 27): "" = SQLite in the root (the embedded default); a postgresql:// URI
  /// = a PostgreSQL index shared by several instances, with single-flight leases. Never holds a
  /// password (refused): that comes from PGPASSWORD, PGPASSFILE or `indexPasswordFile`.
  std::string index;
  std::optional<std::filesystem::path> indexPasswordFile; ///< YAML `index_password_file`
  /** YAML `cache.store` (issue 27): "" keeps the tiles under root (the embedded default);
   * `s3://BUCKET[/PREFIX]` keeps them in S3-compatible object storage (`cache.s3`), the index
   * staying under root. */
  std::string store;
  /** YAML `cache.s3`: where the bucket is. Credentials never come from here: from
   * AWS_ACCESS_KEY_ID / AWS_SECRET_ACCESS_KEY, else the credentials file. */
  struct S3 {
    std::string endpoint;             ///< `http(s)://host[:port]`, path-style requests
    std::string region = "us-east-1"; ///< what requests are signed for
    /** "" = $AWS_SHARED_CREDENTIALS_FILE, else ~/.aws/credentials. */
    std::filesystem::path credentialsFile;
    bool localTier = true; ///< the file tree under root in front of the bucket (a local copy)
    /** YAML `local_tier_limit`: the local tier's tiles are kept under this many bytes by removing
     * local copies only, least recently used first (the bucket and the index keep them); 0 =
     * unbounded. */
    std::uint64_t localTierLimitBytes = 0;
  } s3;
};

/** Why `cache.index` is refused (not a postgresql:// URI, or one holding a password; the message
 * never repeats the password), or nullopt when it is taken. */
std::optional<std::string> checkIndexUri(std::string_view uri);

/** YAML `upstreams[].redirects`: which redirects of an upstream are followed. */
enum class RedirectPolicy {
  SameOrigin, ///< within the origin (scheme, host, port) of the upstream's URL only
  Any,        ///< to any http(s) URL (configured headers still go to the upstream's origin only)
  None,       ///< none: a redirect fails the request
};

/** One entry of YAML `upstreams`: where tiles come from. */
struct UpstreamConfig {
  enum class Type {
    Local,     ///< a georeferenced image on disk (world file next to it)
    Wms,       ///< an OGC WMS 1.1.1 / 1.3.0 server (GetMap)
    WorldWind, ///< a World Wind tile server (T=&L=&X=&Y= appended to the URL)
    Wmts,      ///< an OGC WMTS 1.0.0 server (NASA GIBS): its capabilities at `url`
  };
  /** Wmts: how tiles are asked for (YAML `encoding`). */
  enum class Encoding {
    Auto, ///< REST when the layer has a ResourceURL template for its format, else KVP
    Rest, ///< the layer's ResourceURL template
    Kvp,  ///< GetTile with query parameters
  };

  std::string name; ///< referenced by layers; also the cache's server folder
  Type type = Type::Local;
  std::filesystem::path path; ///< Local: the image, absolute after loading
  std::string url; ///< Wms / WorldWind: http(s) URL, a query string is allowed; Wmts: capabilities
  std::string wmsVersion = "1.3.0"; ///< Wms: "1.1.1" or "1.3.0"
  std::string crs = "EPSG:4326";    ///< Wms: "EPSG:4326" or "CRS:84"
  std::chrono::milliseconds connectTimeout{5'000};
  std::chrono::milliseconds timeout{30'000};           ///< a whole request
  std::chrono::milliseconds retryBackoff{200};         ///< base of exponential backoff with jitter
  std::chrono::milliseconds openInterval{30'000};      ///< circuit breaker open before one probe
  std::chrono::milliseconds maxRetryAfterWait{10'000}; ///< longer Retry-After: pause, fail now
  int maxConnections = 4;                              ///< concurrent requests to this upstream
  int retries = 3;                                     ///< for 5xx and timeouts
  /// Wms: `tellus seed` asks for up to metaTiles x metaTiles tiles with one GetMap (1 = per tile)
  int metaTiles = 4;
  int failureThreshold = 5;           ///< consecutive failures that open the circuit breaker
  Encoding encoding = Encoding::Auto; ///< Wmts only
  std::vector<std::pair<std::string, std::string>> headers; ///< sent with every request, in order
  RedirectPolicy redirects = RedirectPolicy::SameOrigin;    ///< redirects followed (at most 5 hops)
};

/** Imagery: pictures served as sent. Elevation: heights (metres) for the renderer's terrain.
 * Values: measured numbers that tellus colours itself (issue 24; YAML `kind: values`).
 * Elevation layers are value layers too (`isValueLayer`). */
enum class LayerKind { Imagery, Elevation, Values };

/** How the raw samples of an elevation layer become metres. */
enum class ElevationEncoding {
  Bil16,     ///< application/bil16: little-endian Int16, no header
  Int16Tiff, ///< image/tiff with one Int16 band
  Png16,     ///< image/png with one 16-bit band (values as signed Int16)
};

/** YAML `layers[].elevation` (elevation layers only): metres = raw * scale + offset. */
struct ElevationSettings {
  ElevationEncoding encoding = ElevationEncoding::Bil16;
  double scale = 1.0;
  double offset = 0.0;
  double noData = -32768.0; ///< raw value that means "no data"
};

/** YAML `layers[].values`: what a value layer's samples mean and how they are coloured (the
 * values module: tellus/values/). For kind: values every key applies; for an elevation layer
 * only the colouring keys do, and `format` is filled from its `elevation` block (unit "m"; a
 * png16 layer as UInt16 samples of height + 32768, tellus's 16-bit PNG height convention).
 * The colour map named by `colourMap` is the layer's default WMS style; `styles` are the maps it
 * offers (the default among them). */
struct ValueSettings {
  /** container (from the layer's format), encoding, byte order (BIL only), scale, offset,
   * no_data (raw), unit. */
  values::ValueFormat format;
  std::string colourMap{values::kDefaultColourMap};
  std::vector<std::string> styles; ///< colour map names; all of values::colourMaps() by default
  bool rangeFromData = false;      ///< YAML `range: data`: from the values (percentiles below)
  double min = 0.0;                ///< the fixed range (YAML `range: [min, max]`)
  double max = 1.0;
  double lowPercent = 0.0;    ///< YAML `percentiles: [low, high]`, with `range: data` only
  double highPercent = 100.0; ///< (0 and 100: the values' min and max)
  values::Scaling scaling = values::Scaling::Linear;
  values::OutOfRange outOfRange = values::OutOfRange::Clamp;
};

/** YAML `layers[].time`: the WMS TIME dimension. Empty (no values, no period) = no dimension. */
struct TimeDimension {
  /** Every allowed value: as listed, or expanded from `period` when that gives at most
   * kMaxExpandedValues values (otherwise empty and only `period` describes them). */
  std::vector<std::string> values;
  /** ISO 8601 "start/end/period" as written (e.g. "2024-01-01/2024-12-31/P1D"); "" when the
   * values were listed. */
  std::string period;
  /** The default TIME; when not written: the last value, or the end of the period. */
  std::string defaultValue;

  static constexpr std::size_t kMaxExpandedValues = 10000;

  bool enabled() const noexcept { return !values.empty() || !period.empty(); }
};

/** One entry of YAML `layers`: a WMS layer / World Wind dataset served by tellus. */
struct LayerConfig {
  std::string name; ///< [A-Za-z0-9_.-]+, unique; the WMS layer / World Wind dataset name
  std::string title;
  std::string abstract;
  LayerKind kind = LayerKind::Imagery;
  std::string upstream;        ///< name of an entry of Config::upstreams
  std::string upstreamLayer;   ///< WMS LAYERS / World Wind T= value sent upstream (default: name)
  std::int32_t firstLevel = 0; ///< WorldWind: level L here is level L + firstLevel upstream
  /// Wmts: the upstream's tile matrix set (YAML `tile_matrix_set`; "" = the layer's only one)
  std::string tileMatrixSet;
  /** The cached dataset: server = upstream, name = name, grid, mimeType (YAML `format`),
   * extension (jpg, png, bil, tif from the format), style (WMS STYLES sent upstream), pinned
   * (YAML `cache.pinned`). time stays "": one dataset per TIME value is made by the proxy. */
  DatasetSpec dataset;
  ElevationSettings elevation; ///< meaningful for kind == Elevation
  ValueSettings values;        ///< meaningful for value layers (isValueLayer())
  TimeDimension time;
  std::chrono::milliseconds ttl{0};    ///< after this a tile is stale and revalidated; 0 = never
  std::chrono::seconds maxAge{86'400}; ///< Cache-Control max-age sent to clients
  double opacity = 1.0; ///< drawn with this opacity when composed over other layers (0..1)

  /** Values (kind: values) and elevation layers: queryable, with colour-map styles. */
  bool isValueLayer() const noexcept { return kind != LayerKind::Imagery; }
};

struct Config {
  std::filesystem::path sourceFile; ///< the YAML it came from ("<embedded default.yaml>" for that)
  ServerSettings server;
  CacheSettings cache;
  RendererSettings renderer;
  std::vector<BodyConfig> bodies; ///< YAML `bodies`: the configured ones (besides kBuiltinBodies)
  std::vector<UpstreamConfig> upstreams;
  std::vector<LayerConfig> layers;

  /** The layer with this name, or nullptr. */
  const LayerConfig* layer(std::string_view name) const noexcept;
  /** The upstream with this name, or nullptr. */
  const UpstreamConfig* upstream(std::string_view name) const noexcept;
  /** A configured body (not a built-in one) with this name, or nullptr. */
  const BodyConfig* body(std::string_view name) const noexcept;
  /** A built-in or a configured body's name. */
  bool knowsBody(std::string_view name) const noexcept;
};

/** Why a configuration could not be loaded. line and column are 1-based; 0 = unknown (e.g. the
 * file could not be read). key is the dotted path of the offending key, e.g.
 * "layers[1].grid.level_zero_delta" ("" for the whole document). */
struct ConfigError {
  std::string file;
  int line = 0;
  int column = 0;
  std::string key;
  std::string message;

  /** "file:line:column: key.path: message" (the parts that are unknown are left out). */
  std::string toString() const;
};

/** Reads, parses and validates a YAML file. Relative paths in it resolve against its folder. */
std::expected<Config, ConfigError> loadConfig(const std::filesystem::path& file);

/** Parses and validates YAML text. sourceName names it in errors; relative paths in it resolve
 * against baseDir. */
std::expected<Config, ConfigError> parseConfig(std::string_view yamlText,
                                               std::string_view sourceName,
                                               const std::filesystem::path& baseDir);

/** The embedded default (config/examples/default.yaml, compiled in) over the bundled data in
 * dataDir (its relative paths resolve against dataDir), with the cache at cacheRoot (empty: the
 * default cache root). Does not check that the data files exist: call validate(). */
Config embeddedDefault(const std::filesystem::path& dataDir,
                       const std::filesystem::path& cacheRoot);

/** The text of the embedded default YAML. */
std::string_view embeddedDefaultYaml() noexcept;

/** Checks a configuration: unique names, upstream references, valid grids, known formats, kinds
 * and encodings, existing local upstream files, http(s) URLs, positive durations, limits. The
 * message names the layer or upstream and the field. loadConfig / parseConfig run it too. */
std::expected<void, std::string> validate(const Config& config);

/** The default cache root: $TELLUS_CACHE, else $XDG_CACHE_HOME/tellus, else ~/.cache/tellus. */
std::filesystem::path defaultCacheRoot();

/** A duration as written in a configuration: an integer and a unit, ms, s, m, h or d ("500ms",
 * "30s", "5m", "12h", "30d"); a bare "0" is zero. std::nullopt for anything else or on overflow. */
std::optional<std::chrono::milliseconds> parseDurationText(std::string_view text) noexcept;

/** A size in bytes: an integer, optionally with B, KB, MB, GB, TB (powers of 1000) or KiB, MiB,
 * GiB, TiB (powers of 1024): "1000000", "512MiB", "10GiB". std::nullopt on anything else or on
 * overflow of 64 bits. */
std::optional<std::uint64_t> parseSizeText(std::string_view text) noexcept;

} // namespace tellus
