// Validation of a typed configuration: what YAML types cannot say (cross references, grids,
// formats, ranges, files). Each problem names its YAML key so that the parser can point at the
// line.

#include "ConfigInternal.hpp"

#include <tellus/values/ColourMap.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <system_error>

namespace tellus {
namespace detail {

namespace {

std::string str(std::int64_t v) {
  return std::to_string(v);
}

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

bool hasControl(std::string_view s) noexcept {
  return std::any_of(s.begin(), s.end(), [](char c) {
    const auto u = static_cast<unsigned char>(c);
    return u < 0x20 || u == 0x7f;
  });
}

/** The file suffix of a known format, or "". */
std::string_view extensionOf(std::string_view mimeType) noexcept {
  if (mimeType == "image/jpeg") return "jpg";
  if (mimeType == "image/png") return "png";
  if (mimeType == "application/bil16") return "bil";
  if (mimeType == "image/tiff") return "tif";
  return {};
}

/** TileGrid's field names in YAML words, and the key of the grid field the message is about. */
std::pair<std::string, std::string> gridMessage(const std::string& message) {
  std::string key = "grid";
  if (message.starts_with("levelZeroDeltaDeg"))
    key = "grid.level_zero_delta";
  else if (message.starts_with("numLevels"))
    key = "grid.levels";
  else if (message.starts_with("tile"))
    key = "grid.tile_size";
  else if (message.starts_with("sector"))
    key = "grid.sector";
  std::string m = message;
  const std::pair<std::string_view, std::string_view> words[] = {
      {"levelZeroDeltaDeg", "level_zero_delta"},
      {"numLevels", "levels"},
      {"tileWidth", "tile width"},
      {"tileHeight", "tile height"},
      {"sector.", "sector "},
  };
  for (const auto& [from, to] : words) {
    for (auto pos = m.find(from); pos != std::string::npos; pos = m.find(from, pos + to.size()))
      m.replace(pos, from.size(), to);
  }
  return {key, m};
}

using UpstreamIndex = std::map<std::string_view, const UpstreamConfig*>;

std::optional<ValidationIssue> checkServer(const ServerSettings& s) {
  const auto issue = [](std::string key, std::string message) {
    return ValidationIssue{"server." + key, "server", std::move(message)};
  };
  if (s.listenHost.empty() || hasControl(s.listenHost) ||
      s.listenHost.find(' ') != std::string::npos)
    return issue("listen", "the listen host '" + s.listenHost + "' is empty or has blanks");
  if (!s.publicUrl.empty()) {
    if (auto e = checkHttpUrl(s.publicUrl)) return issue("public_url", *e);
  }
  if (hasControl(s.cors)) return issue("cors", "has a control character");
  if (s.threads < 0 || s.threads > 256)
    return issue("threads", "must be in [0, 256] (0 = automatic), got " + str(s.threads));
  const ServerLimits& l = s.limits;
  if (l.maxConnections < 1 || l.maxConnections > 1'000'000)
    return issue("limits.max_connections", "must be in [1, 1000000], got " + str(l.maxConnections));
  if (l.maxHeaderBytes < 256 || l.maxHeaderBytes > (1U << 20))
    return issue("limits.max_header_bytes",
                 "must be in [256, 1048576] bytes, got " +
                     std::to_string(static_cast<unsigned long long>(l.maxHeaderBytes)));
  if (l.maxParamBytes < 1 || l.maxParamBytes > l.maxHeaderBytes)
    return issue("limits.max_param_bytes",
                 "must be in [1, max_header_bytes], got " +
                     std::to_string(static_cast<unsigned long long>(l.maxParamBytes)));
  if (l.maxWidth < 1 || l.maxWidth > 65536)
    return issue("limits.max_width", "must be in [1, 65536] pixels, got " + str(l.maxWidth));
  if (l.maxHeight < 1 || l.maxHeight > 65536)
    return issue("limits.max_height", "must be in [1, 65536] pixels, got " + str(l.maxHeight));
  if (l.requestTimeout.count() <= 0)
    return issue("limits.request_timeout", "must be longer than 0");
  if (l.keepaliveTimeout.count() < 0)
    return issue("limits.keepalive_timeout", "must not be negative");
  if (!std::isfinite(l.requestsPerSecond) || l.requestsPerSecond < 0.0)
    return issue("limits.requests_per_second", "must be a finite number >= 0");
  if (!std::isfinite(l.fetchesPerClientPerMinute) || l.fetchesPerClientPerMinute < 0.0)
    return issue("limits.fetches_per_client_per_minute", "must be a finite number >= 0");
  const CdnSettings& c = s.cdn;
  if (c.sMaxAge && c.sMaxAge->count() < 0) return issue("cdn.s_maxage", "must not be negative");
  if (c.staleWhileRevalidate && c.staleWhileRevalidate->count() < 0)
    return issue("cdn.stale_while_revalidate", "must not be negative");
  if (c.staleIfError.count() < 0) return issue("cdn.stale_if_error", "must not be negative");
  if (c.shortMaxAge.count() < 0) return issue("cdn.short_max_age", "must not be negative");
  if (!std::all_of(c.keyHeader.begin(), c.keyHeader.end(), [](char ch) {
        return std::isalnum(static_cast<unsigned char>(ch)) || ch == '-' || ch == '_';
      }))
    return issue("cdn.key_header",
                 "must be a header name (A-Z a-z 0-9 - _), got '" + c.keyHeader + "'");
  for (std::size_t i = 0; i < c.purge.size(); ++i)
    if (auto e = checkHttpUrl(c.purge[i])) return issue("cdn.purge[" + std::to_string(i) + "]", *e);
  return std::nullopt;
}

std::optional<ValidationIssue>
checkUpstream(const UpstreamConfig& u, std::size_t i, bool checkFiles) {
  const std::string base = "upstreams[" + std::to_string(i) + "]";
  const std::string subject = "upstream '" + u.name + "'";
  const auto issue = [&](const std::string& key, std::string message) {
    return ValidationIssue{base + (key.empty() ? "" : "." + key), subject, std::move(message)};
  };
  if (!isValidName(u.name))
    return issue("name", "the name must be non-empty and use only A-Z a-z 0-9 _ . -");
  if (u.type == UpstreamConfig::Type::Local) {
    if (u.path.empty()) return issue("path", "a local upstream needs one");
    if (checkFiles) {
      std::error_code ec;
      const auto st = std::filesystem::status(u.path, ec);
      if (!std::filesystem::exists(st))
        return issue("path", "the file " + u.path.string() + " does not exist");
      if (!std::filesystem::is_regular_file(st))
        return issue("path", u.path.string() + " is not a regular file");
    }
    return std::nullopt;
  }
  if (u.url.empty()) return issue("url", "a wms / worldwind / wmts upstream needs one");
  if (auto e = checkHttpUrl(u.url)) return issue("url", *e);
  if (u.type == UpstreamConfig::Type::Wms) {
    if (u.wmsVersion != "1.1.1" && u.wmsVersion != "1.3.0")
      return issue("version", "must be 1.1.1 or 1.3.0, got '" + u.wmsVersion + "'");
    if (u.crs != "EPSG:4326" && u.crs != "CRS:84")
      return issue("crs", "must be EPSG:4326 or CRS:84, got '" + u.crs + "'");
  }
  if (u.connectTimeout.count() <= 0) return issue("connect_timeout", "must be longer than 0");
  if (u.timeout.count() <= 0) return issue("timeout", "must be longer than 0");
  if (u.retryBackoff.count() < 0) return issue("retry_backoff", "must not be negative");
  if (u.openInterval.count() <= 0) return issue("open_interval", "must be longer than 0");
  if (u.maxRetryAfterWait.count() < 0) return issue("max_retry_after_wait", "must not be negative");
  if (u.maxConnections < 1 || u.maxConnections > 1024)
    return issue("max_connections", "must be in [1, 1024], got " + str(u.maxConnections));
  if (u.metaTiles < 1 || u.metaTiles > 16)
    return issue("meta_tiles", "must be in [1, 16], got " + str(u.metaTiles));
  if (u.retries < 0 || u.retries > 100)
    return issue("retries", "must be in [0, 100], got " + str(u.retries));
  if (u.failureThreshold < 1 || u.failureThreshold > 1'000'000)
    return issue("failure_threshold", "must be in [1, 1000000], got " + str(u.failureThreshold));
  if (u.headers.size() > 100) return issue("headers", "more than 100 headers");
  for (const auto& [name, value] : u.headers) {
    if (!isHttpToken(name))
      return issue("headers", "'" + name + "' is not a valid HTTP header name");
    const bool control = std::any_of(value.begin(), value.end(), [](char ch) {
      const auto b = static_cast<unsigned char>(ch);
      return (b < 0x20 && ch != '\t') || b == 0x7f;
    });
    if (control)
      return issue("headers." + name, "the value has a control character (CR, LF, NUL ...)");
  }
  return std::nullopt;
}

std::optional<ValidationIssue>
checkTime(const TimeDimension& t, const std::string& base, const std::string& subject) {
  const auto issue = [&](const std::string& key, std::string message) {
    return ValidationIssue{
        base + ".time" + (key.empty() ? "" : "." + key), subject, std::move(message)};
  };
  if (!t.enabled()) {
    if (!t.defaultValue.empty()) return issue("default", "a default without values or a period");
    return std::nullopt;
  }
  std::optional<TimePeriod> period;
  if (!t.period.empty()) {
    auto p = parseTimePeriod(t.period, TimeDimension::kMaxExpandedValues);
    if (!p) return issue("period", p.error());
    period = std::move(*p);
  }
  std::set<std::string_view> seen;
  for (const auto& v : t.values) {
    if (v.empty() || hasControl(v) || v.find_first_of(", ") != std::string::npos)
      return issue("values", "'" + v + "' is empty or has a comma, a blank or a control character");
    if (!seen.insert(v).second) return issue("values", "'" + v + "' is listed twice");
  }
  if (t.defaultValue.empty()) return issue("default", "the default is empty");
  if (!t.values.empty()) {
    if (!seen.contains(t.defaultValue))
      return issue("default", "the default '" + t.defaultValue + "' is not one of the values");
  } else if (period) {
    const auto d = iso8601::parseInstant(t.defaultValue);
    if (!d || d->seconds < period->start.seconds || d->seconds > period->end.seconds)
      return issue("default",
                   "the default '" + t.defaultValue + "' is not a time inside the period");
  }
  return std::nullopt;
}

/** Builds the issues of one layer: layers[i].<key>, about "layer '<name>'". */
class LayerIssue {
public:
  LayerIssue(const LayerConfig& l, std::size_t i)
      : base_("layers[" + std::to_string(i) + "]"), subject_("layer '" + l.name + "'") {}
  ValidationIssue operator()(const std::string& key, std::string message) const {
    return ValidationIssue{base_ + (key.empty() ? "" : "." + key), subject_, std::move(message)};
  }
  const std::string& base() const noexcept { return base_; }
  const std::string& subject() const noexcept { return subject_; }

private:
  std::string base_;
  std::string subject_;
};

/** "no upstream named 'x' (upstreams: a, b, ...)": the first ten names. */
ValidationIssue unknownUpstream(const Config& c, const LayerConfig& l, const LayerIssue& issue) {
  std::string names;
  for (std::size_t k = 0; k < c.upstreams.size() && k < 10; ++k)
    names += (names.empty() ? "" : ", ") + c.upstreams[k].name;
  if (c.upstreams.size() > 10) names += ", ...";
  return issue("upstream",
               "no upstream named '" + l.upstream +
                   "' (upstreams: " + (names.empty() ? "none" : names) + ")");
}

/** The format, its file suffix, the style and upstream layer names, and the kind the format
 * allows. */
std::optional<ValidationIssue> checkLayerFormat(const LayerConfig& l, const LayerIssue& issue) {
  const std::string& m = l.dataset.mimeType;
  const std::string_view ext = extensionOf(m);
  if (ext.empty())
    return issue("format",
                 "'" + m + "' is not one of image/jpeg, image/png, application/bil16, image/tiff");
  if (l.dataset.extension != ext)
    return issue("format",
                 "extension '" + l.dataset.extension + "' does not match format " + m +
                     " (expected " + std::string(ext) + ")");
  if (hasControl(l.dataset.style)) return issue("style", "has a control character");
  if (l.upstreamLayer.empty() || hasControl(l.upstreamLayer))
    return issue("upstream_layer", "is empty or has a control character");
  if (l.kind == LayerKind::Imagery && m == "application/bil16")
    return issue("kind", "format application/bil16 carries heights: the kind must be elevation");
  return std::nullopt;
}

/** An elevation layer's format (lossless), encoding (fitting the format) and its numbers. */
std::optional<ValidationIssue> checkElevation(const LayerConfig& l, const LayerIssue& issue) {
  const std::string& m = l.dataset.mimeType;
  if (m == "image/jpeg")
    return issue("format", "an elevation layer needs a lossless format, not image/jpeg");
  const auto enc = l.elevation.encoding;
  const bool matches = (enc == ElevationEncoding::Bil16 && m == "application/bil16") ||
                       (enc == ElevationEncoding::Int16Tiff && m == "image/tiff") ||
                       (enc == ElevationEncoding::Png16 && m == "image/png");
  if (!matches)
    return issue("elevation.encoding",
                 "the encoding does not fit format " + m +
                     " (bil16: application/bil16, int16-tiff: image/tiff, png16: image/png)");
  if (!std::isfinite(l.elevation.scale) || l.elevation.scale == 0.0)
    return issue("elevation.scale", "must be a finite number other than 0");
  if (!std::isfinite(l.elevation.offset))
    return issue("elevation.offset", "must be a finite number");
  if (!std::isfinite(l.elevation.noData))
    return issue("elevation.no_data", "must be a finite number");
  return std::nullopt;
}

std::optional<ValidationIssue>
checkLayer(const Config& c, const UpstreamIndex& upstreams, const LayerConfig& l, std::size_t i) {
  const LayerIssue issue(l, i);
  if (!isValidName(l.name))
    return issue("name", "the name must be non-empty and use only A-Z a-z 0-9 _ . -");
  const auto found = upstreams.find(l.upstream);
  const UpstreamConfig* up = found == upstreams.end() ? nullptr : found->second;
  if (!up) return unknownUpstream(c, l, issue);
  if (l.dataset.name != l.name)
    return issue("", "dataset.name '" + l.dataset.name + "' differs from the layer name");
  if (l.dataset.server != l.upstream)
    return issue("", "dataset.server '" + l.dataset.server + "' differs from the upstream name");
  if (auto g = TileGrid::create(l.dataset.grid); !g) {
    auto [key, message] = gridMessage(g.error());
    return issue(key, message);
  }
  if (auto e = checkLayerFormat(l, issue)) return e;
  if (l.kind == LayerKind::Elevation) {
    if (auto e = checkElevation(l, issue)) return e;
  }
  if (l.isValueLayer()) {
    if (auto e = checkValueSettings(l)) return issue(e->first, e->second);
  }
  if (!l.tileMatrixSet.empty() && up->type != UpstreamConfig::Type::Wmts)
    return issue("tile_matrix_set", "applies to layers of wmts upstreams only");
  if (l.firstLevel != 0) {
    if (up->type != UpstreamConfig::Type::WorldWind)
      return issue("grid.first_level", "applies to worldwind upstreams only");
    if (l.firstLevel < 0 || l.firstLevel > kMaxLevel + 1 - l.dataset.grid.numLevels)
      return issue("grid.first_level",
                   "must be in [0, " + str(kMaxLevel + 1 - l.dataset.grid.numLevels) +
                       "] so that first_level + levels <= " + str(kMaxLevel + 1) + ", got " +
                       str(l.firstLevel));
  }
  if (auto t = checkTime(l.time, issue.base(), issue.subject())) return t;
  if (l.ttl.count() < 0) return issue("cache.ttl", "must not be negative");
  if (l.maxAge.count() < 0) return issue("cache.max_age", "must not be negative");
  return std::nullopt;
}

/** renderer.atmosphere: (key, message) of the first bad value. */
std::optional<std::pair<std::string, std::string>> checkAtmosphere(const AtmosphereSettings& a) {
  using Bad = std::pair<std::string, std::string>;
  const auto in = [](double v, double lo, double hi) { return v > lo && v <= hi; };
  const auto rgb = [](const std::array<double, 3>& v, double hi) {
    return std::ranges::all_of(v, [hi](double x) { return x >= 0.0 && x <= hi; });
  };
  if (!in(a.exposure, 0.0, 1e6)) return Bad{"atmosphere.exposure", "must be in (0, 1e6]"};
  if (!(a.bottomRadius == 0.0 || in(a.bottomRadius, 1e3, 1e9)))
    return Bad{"atmosphere.bottom_radius", "must be 0 (the body's) or in (1e3, 1e9] metres"};
  if (!in(a.topAltitude, 0.0, 1e6))
    return Bad{"atmosphere.top_altitude", "must be in (0, 1e6] metres"};
  if (!rgb(a.rayleighScattering, 1.0) || !rgb(a.ozoneAbsorption, 1.0))
    return Bad{"atmosphere.rayleigh_scattering",
               "and ozone_absorption must be three numbers in [0, 1] per metre"};
  if (!rgb(a.solarIrradiance, 1e6))
    return Bad{"atmosphere.solar_irradiance", "must be three numbers in [0, 1e6]"};
  if (!rgb(a.groundAlbedo, 1.0))
    return Bad{"atmosphere.ground_albedo", "must be three numbers in [0, 1]"};
  if (!in(a.rayleighScaleHeight, 0.0, 1e6) || !in(a.mieScaleHeight, 0.0, 1e6) ||
      !in(a.ozoneHalfWidth, 0.0, 1e6) || !(std::abs(a.ozoneCentre) <= 1e6))
    return Bad{"atmosphere.rayleigh_scale_height",
               "scale heights and the ozone layer's half width must be in (0, 1e6] metres, its "
               "centre in [-1e6, 1e6]"};
  if (!(a.mieScattering >= 0.0 && a.mieExtinction >= a.mieScattering && a.mieExtinction <= 1.0))
    return Bad{"atmosphere.mie_extinction", "must be >= mie_scattering >= 0 and <= 1 per metre"};
  if (!(a.mieG > -1.0 && a.mieG < 1.0)) return Bad{"atmosphere.mie_g", "must be in (-1, 1)"};
  if (!(a.sunAngularRadius > 0.0 && a.sunAngularRadius < 0.1))
    return Bad{"atmosphere.sun_angular_radius", "must be in (0, 0.1) radians"};
  if (!(a.minSunCosine > -1.0 && a.minSunCosine < 0.0))
    return Bad{"atmosphere.min_sun_cosine", "must be in (-1, 0)"};
  return std::nullopt;
}

} // namespace

std::optional<std::pair<std::string, std::string>>
checkAtmosphereSettings(const AtmosphereSettings& a) {
  return checkAtmosphere(a);
}

std::optional<ValidationIssue> checkRenderer(const RendererSettings& g) {
  const auto issue = [](std::string key, std::string message) {
    return ValidationIssue{"renderer." + key, "renderer", std::move(message)};
  };
  if (!(g.lodThreshold >= 0.05 && g.lodThreshold <= 64.0))
    return issue("lod_threshold", "must be in [0.05, 64], got " + num(g.lodThreshold));
  const int n = g.meshSize - 1;
  if (g.meshSize < 3 || g.meshSize > 257 || (n & (n - 1)) != 0)
    return issue("mesh_size", "must be 2^k + 1 in [3, 257], got " + str(g.meshSize));
  if (!(g.fovDeg > 1.0 && g.fovDeg < 170.0))
    return issue("fov", "must be in (1, 170) degrees, got " + num(g.fovDeg));
  if (g.textureBudget < (std::uint64_t{1} << 20))
    return issue("texture_budget", "must be at least 1MiB");
  if (g.uploadPerFrame < 4096) return issue("upload_per_frame", "must be at least 4KiB");
  if (g.maxInFlight < 1 || g.maxInFlight > 1024)
    return issue("max_in_flight", "must be in [1, 1024], got " + str(g.maxInFlight));
  if (g.maxSplitsPerFrame < 1 || g.maxSplitsPerFrame > 100000)
    return issue("max_splits_per_frame", "must be in [1, 100000], got " + str(g.maxSplitsPerFrame));
  if (g.decodeThreads < 1 || g.decodeThreads > 64)
    return issue("decode_threads", "must be in [1, 64], got " + str(g.decodeThreads));
  if (!(g.fadeInS >= 0.0 && g.fadeInS <= 10.0))
    return issue("fade_in", "must be in [0, 10] seconds, got " + num(g.fadeInS));
  if (!(g.dome.fovDeg > 0.0 && g.dome.fovDeg <= 220.0))
    return issue("dome.fov", "must be in (0, 220] degrees, got " + num(g.dome.fovDeg));
  if (!(g.dome.tiltDeg >= -180.0 && g.dome.tiltDeg <= 180.0))
    return issue("dome.tilt", "must be in [-180, 180] degrees, got " + num(g.dome.tiltDeg));
  if (!(g.dome.faceScale >= 0.1 && g.dome.faceScale <= 4.0))
    return issue("dome.face_scale", "must be in [0.1, 4], got " + num(g.dome.faceScale));
  if (!(g.dome.directMaxErrorPx >= 0.0 && g.dome.directMaxErrorPx <= 1e9))
    return issue("dome.direct_max_error",
                 "must be in [0, 1e9] pixels, got " + num(g.dome.directMaxErrorPx));
  if (!(g.stars.magnitudeLimit >= -2.0 && g.stars.magnitudeLimit <= 25.0))
    return issue("stars.magnitude_limit",
                 "must be in [-2, 25], got " + num(g.stars.magnitudeLimit));
  if (!(g.stars.brightness >= 0.0 && g.stars.brightness <= 100.0))
    return issue("stars.brightness", "must be in [0, 100], got " + num(g.stars.brightness));
  if (auto a = checkAtmosphere(g.atmosphere)) return issue(a->first, a->second);
  const TerrainSettings& t = g.terrain;
  if (!(t.exaggeration > 0.0 && t.exaggeration <= 100.0))
    return issue("terrain.exaggeration", "must be in (0, 100], got " + num(t.exaggeration));
  if (!(t.clearanceM >= 0.0 && t.clearanceM <= 1e6))
    return issue("terrain.clearance", "must be in [0, 1e6] metres, got " + num(t.clearanceM));
  if (!(t.minReliefPx >= 0.0 && t.minReliefPx <= 100.0))
    return issue("terrain.min_relief_px", "must be in [0, 100] pixels, got " + num(t.minReliefPx));
  if (t.sun && !((*t.sun)[0] >= -90.0 && (*t.sun)[0] <= 90.0 && std::isfinite((*t.sun)[1])))
    return issue("terrain.sun", "must be [lat, lon] with lat in [-90, 90]");
  if (g.overlaysPerPass < 0 || g.overlaysPerPass > 8)
    return issue("overlays_per_pass",
                 "must be in [0, 8] (0: as the GPU allows), got " + str(g.overlaysPerPass));
  if (g.earth != EarthShape::Wgs84 && g.earth != EarthShape::Sphere)
    return issue("earth", "must be wgs84 or sphere");
  if (!g.time.empty() && g.time != "now" && !iso8601::parseInstant(g.time))
    return issue(
        "time", "must be an ISO 8601 UTC time (2024-06-20T12:00:00Z) or now, got '" + g.time + "'");
  return std::nullopt;
}

namespace {

/** Each upstream, and its name used once; fills the index of upstreams by name. */
std::optional<ValidationIssue>
checkUpstreams(const Config& c, bool checkFiles, UpstreamIndex& upstreams) {
  for (std::size_t i = 0; i < c.upstreams.size(); ++i) {
    const auto& u = c.upstreams[i];
    if (auto e = checkUpstream(u, i, checkFiles)) return e;
    if (!upstreams.emplace(u.name, &u).second)
      return ValidationIssue{"upstreams[" + std::to_string(i) + "].name",
                             "upstream '" + u.name + "'",
                             "the name is used twice"};
  }
  return std::nullopt;
}

/** Each layer, and its name used once. */
std::optional<ValidationIssue> checkLayers(const Config& c, const UpstreamIndex& upstreams) {
  std::set<std::string_view> layers;
  for (std::size_t i = 0; i < c.layers.size(); ++i) {
    const auto& l = c.layers[i];
    if (auto e = checkLayer(c, upstreams, l, i)) return e;
    if (!layers.insert(l.name).second)
      return ValidationIssue{"layers[" + std::to_string(i) + "].name",
                             "layer '" + l.name + "'",
                             "the name is used twice"};
  }
  return std::nullopt;
}

/** Regional datasets share their layer's grid (a key is the same sector in each). */
bool sameGrid(const LayerConfig& a, const LayerConfig& b) {
  const GridSpec &x = a.dataset.grid, &y = b.dataset.grid;
  return x.levelZeroDeltaDeg == y.levelZeroDeltaDeg && x.tileWidth == y.tileWidth &&
         x.tileHeight == y.tileHeight;
}

/** The regional layers of a renderer entry at `at`: layers of the kind, on main's grid. */
std::optional<ValidationIssue> checkRegional(const Config& c,
                                             const std::vector<std::string>& names,
                                             const LayerConfig* main,
                                             LayerKind kind,
                                             const std::string& at) {
  for (std::size_t j = 0; j < names.size(); ++j) {
    const std::string p = at + ".regional[" + std::to_string(j) + "]";
    const auto* l = c.layer(names[j]);
    if (l == nullptr || l->kind != kind)
      return ValidationIssue{p,
                             "renderer",
                             "'" + names[j] + "' is not " +
                                 (kind == LayerKind::Imagery  ? "an imagery"
                                  : kind == LayerKind::Values ? "a value"
                                                              : "an elevation") +
                                 " layer"};
    if (main != nullptr && !sameGrid(*main, *l))
      return ValidationIssue{p,
                             "renderer",
                             "'" + names[j] +
                                 "' has another grid (level_zero_delta, tile_size) "
                                 "than '" +
                                 main->name + "'"};
  }
  return std::nullopt;
}

/** renderer.terrain: its layer an elevation one, its regional ones on the grid of the elevation
 * layer it uses (the named one, else the first). */
std::optional<ValidationIssue> checkTerrainLayers(const Config& c) {
  if (const std::string& t = c.renderer.terrain.layer; !t.empty()) {
    const auto* l = c.layer(t);
    if (l == nullptr || l->kind != LayerKind::Elevation)
      return ValidationIssue{
          "renderer.terrain.layer", "renderer", "'" + t + "' is not an elevation layer"};
  }
  const LayerConfig* elevation = nullptr;
  for (const auto& l : c.layers)
    if (l.kind == LayerKind::Elevation &&
        (c.renderer.terrain.layer.empty() || l.name == c.renderer.terrain.layer)) {
      elevation = &l;
      break;
    }
  return checkRegional(
      c, c.renderer.terrain.regional, elevation, LayerKind::Elevation, "renderer.terrain");
}

/** renderer.layers[i] over the base drawn as colours (issue 24): colour_map a known map, range
 * min < max (log: above 0); both only for value layers. */
std::optional<ValidationIssue>
checkRenderValues(const RenderLayerSettings& rl, const LayerConfig& l, const std::string& at) {
  if (!l.isValueLayer() && (!rl.colourMap.empty() || rl.range))
    return ValidationIssue{at, "renderer", "colour_map and range apply to value layers only"};
  if (!rl.colourMap.empty() && values::findColourMap(rl.colourMap) == nullptr)
    return ValidationIssue{
        at + ".colour_map", "renderer", "'" + rl.colourMap + "' is not a colour map"};
  if (rl.range) {
    const auto [lo, hi] = *rl.range;
    if (!(std::isfinite(lo) && std::isfinite(hi) && lo < hi))
      return ValidationIssue{at + ".range", "renderer", "must be [min, max] with min < max"};
    if (l.values.scaling == values::Scaling::Log && !(lo > 0.0))
      return ValidationIssue{at + ".range", "renderer", "a log scale's range must be above 0"};
  }
  return std::nullopt;
}

/** renderer.layers[i]: an imagery layer first (the opaque base), then imagery or value layers
 * on its grid; opacity, max_level, a TIME value of the layer, its regional layers. */
std::optional<ValidationIssue>
checkRenderLayer(const Config& c, std::size_t i, const LayerConfig*& base) {
  const RenderLayerSettings& rl = c.renderer.layers[i];
  const std::string at = "renderer.layers[" + std::to_string(i) + "]";
  const auto* l = c.layer(rl.layer);
  if (l == nullptr || (i == 0 && l->kind != LayerKind::Imagery))
    return ValidationIssue{at + ".layer", "renderer", "'" + rl.layer + "' is not an imagery layer"};
  if (auto e = checkRenderValues(rl, *l, at)) return e;
  if (i == 0) {
    base = l;
    if ((rl.opacity && *rl.opacity != 1.0) || !rl.visible || rl.night)
      return ValidationIssue{at,
                             "renderer",
                             "the first entry is the opaque base: opacity, visible and night "
                             "apply to the overlays after it"};
  } else if (l->dataset.grid.levelZeroDeltaDeg != base->dataset.grid.levelZeroDeltaDeg) {
    return ValidationIssue{at + ".layer",
                           "renderer",
                           "'" + rl.layer + "' has another level_zero_delta than the base '" +
                               base->name + "': an overlay must share the base's grid"};
  }
  if (rl.opacity && !(*rl.opacity >= 0.0 && *rl.opacity <= 1.0))
    return ValidationIssue{
        at + ".opacity", "renderer", "must be in [0, 1], got " + num(*rl.opacity)};
  if (rl.maxLevel < -1 || rl.maxLevel > 40)
    return ValidationIssue{
        at + ".max_level", "renderer", "must be in [0, 40], got " + str(rl.maxLevel)};
  if (!rl.time.empty()) {
    if (!l->time.enabled())
      return ValidationIssue{at + ".time", "renderer", "'" + rl.layer + "' has no TIME dimension"};
    if (!l->time.values.empty() &&
        std::find(l->time.values.begin(), l->time.values.end(), rl.time) == l->time.values.end())
      return ValidationIssue{
          at + ".time", "renderer", "'" + rl.time + "' is not a TIME value of '" + rl.layer + "'"};
  }
  return checkRegional(c, rl.regional, l, l->kind, at);
}

} // namespace

std::optional<ValidationIssue> findIssue(const Config& c, bool checkFiles) {
  if (auto s = checkServer(c.server)) return s;
  if (auto g = checkRenderer(c.renderer)) return g;
  if (auto b = checkBodies(c)) return b;
  if (c.cache.root.empty()) return ValidationIssue{"cache.root", "cache", "is empty"};
  UpstreamIndex upstreams;
  if (auto e = checkUpstreams(c, checkFiles, upstreams)) return e;
  if (auto e = checkLayers(c, upstreams)) return e;
  if (auto e = checkTerrainLayers(c)) return e;
  const LayerConfig* base = nullptr;
  for (std::size_t i = 0; i < c.renderer.layers.size(); ++i)
    if (auto e = checkRenderLayer(c, i, base)) return e;
  if (const std::string& o = c.renderer.overview; !o.empty()) {
    const auto* l = c.layer(o);
    if (l == nullptr || l->kind != LayerKind::Imagery)
      return ValidationIssue{
          "renderer.overview", "renderer", "'" + o + "' is not an imagery layer"};
  }
  return std::nullopt;
}

} // namespace detail

std::expected<void, std::string> validate(const Config& config) {
  if (auto issue = detail::findIssue(config, true)) return std::unexpected(issue->text());
  return {};
}

} // namespace tellus
