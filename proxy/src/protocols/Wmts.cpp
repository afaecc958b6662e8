// WMTS 1.0.0 requests (KVP and RESTful) and the tile matrix sets' arithmetic (Wmts.hpp).
#include <tellus/proxy/Wmts.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <numbers>

namespace tellus {

namespace {

/** Metres per degree on the WGS 84 semi-major axis, the unit OGC scale denominators use for
 * degrees (17-083r2, 07-057r7 6.1.a). */
constexpr double kMetresPerDegree = 6378137.0 * std::numbers::pi / 180.0;
/** The standardized rendering pixel (0.28 mm). */
constexpr double kPixelMetres = 0.00028;
constexpr std::int32_t kMaxComposedLevels = 25;
constexpr std::string_view kCrs84 = "urn:ogc:def:crs:OGC:1.3:CRS84";
constexpr std::string_view kEpsg3857 = "urn:ogc:def:crs:EPSG::3857";

OgcException err(std::string_view code, std::string_view locator, std::string message) {
  return OgcException{std::string(code), std::string(locator), std::move(message)};
}

bool iequals(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           const auto lower = [](char c) { return c >= 'A' && c <= 'Z' ? char(c - 'A' + 'a') : c; };
           return lower(x) == lower(y);
         });
}

std::optional<std::int64_t> wholeNumber(std::string_view s) {
  if (s.empty() || s.size() > 18 ||
      !std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return std::nullopt;
  std::int64_t v = 0;
  std::from_chars(s.data(), s.data() + s.size(), v);
  return v;
}

/** The tiles of a matrix that a box (set units) covers with non-zero area, clamped. */
void limitTo(WmtsTileMatrix& m, const Sector& box) {
  const auto cell = [&](double units, std::int64_t count, bool upper) {
    const double t = units / m.tileSpan;
    const double r = std::round(t);
    const double snapped = std::fabs(t - r) < 1e-9 * std::max(1.0, std::fabs(t)) ? r : t;
    const double c = upper ? std::ceil(snapped) - 1 : std::floor(snapped);
    return std::clamp(static_cast<std::int64_t>(c), std::int64_t{0}, count - 1);
  };
  m.minCol = cell(box.west - m.left, m.matrixWidth, false);
  m.maxCol = cell(box.east - m.left, m.matrixWidth, true);
  m.minRow = cell(m.top - box.north, m.matrixHeight, false);
  m.maxRow = cell(m.top - box.south, m.matrixHeight, true);
}

double mercatorY(double latDeg) {
  const double lat = std::clamp(latDeg, -kWebMercatorMaxLat, kWebMercatorMaxLat);
  return 6378137.0 * std::log(std::tan(std::numbers::pi / 4 + lat * std::numbers::pi / 360.0));
}

} // namespace

// ---- tile matrix sets ---------------------------------------------------------------------------

WmtsTileMatrixSet
worldWindMatrixSet(std::string_view layer, const GridSpec& grid, std::int32_t firstLevel) {
  WmtsTileMatrixSet s;
  s.identifier = "WorldWind_" + std::string(layer);
  s.kind = WmtsSetKind::WorldWind;
  s.crs = kCrs84;
  s.firstLevel = std::clamp(firstLevel, 0, grid.numLevels - 1);
  for (std::int32_t level = s.firstLevel; level < grid.numLevels; ++level) {
    WmtsTileMatrix m;
    m.identifier = std::to_string(level);
    m.tileSpan = std::ldexp(grid.levelZeroDeltaDeg, -level);
    m.tileWidth = grid.tileWidth;
    m.tileHeight = grid.tileHeight;
    m.left = -180.0;
    m.top = 90.0;
    m.matrixWidth = static_cast<std::int64_t>(std::llround(360.0 / grid.levelZeroDeltaDeg))
                    << level;
    m.matrixHeight = static_cast<std::int64_t>(std::llround(180.0 / grid.levelZeroDeltaDeg))
                     << level;
    m.scaleDenominator = m.tileSpan / grid.tileWidth * kMetresPerDegree / kPixelMetres;
    limitTo(m, grid.sector);
    s.matrices.push_back(std::move(m));
  }
  return s;
}

WmtsTileMatrixSet bodyWorldWindMatrixSet(std::string_view layer,
                                         const GridSpec& grid,
                                         std::int32_t firstLevel,
                                         const BodyCrs& body) {
  WmtsTileMatrixSet s = worldWindMatrixSet(layer, grid, firstLevel);
  s.crs = iauCrsUrn(body.iauCode);
  s.latFirst = true;
  const double metresPerDegree = body.meanRadiusM * std::numbers::pi / 180.0;
  for (WmtsTileMatrix& m : s.matrices)
    m.scaleDenominator = m.tileSpan / m.tileWidth * metresPerDegree / kPixelMetres;
  return s;
}

std::int32_t composedLevels(WmtsSetKind kind, const GridSpec& grid) {
  const double finestDeg =
      std::ldexp(grid.levelZeroDeltaDeg, -(grid.numLevels - 1)) / grid.tileWidth;
  // Level 0's pixel in degrees (WorldCRS84Quad) or in degrees of longitude at the equator.
  const double level0 = kind == WmtsSetKind::GoogleMapsCompatible ? 360.0 / 256 : 180.0 / 256;
  std::int32_t z = 0;
  while (z + 1 < kMaxComposedLevels && std::ldexp(level0, -z) > finestDeg * (1 + 1e-9))
    ++z;
  return z + 1;
}

WmtsTileMatrixSet composedMatrixSet(WmtsSetKind kind, const Sector& coverage, std::int32_t levels) {
  WmtsTileMatrixSet s;
  const bool mercator = kind == WmtsSetKind::GoogleMapsCompatible;
  s.kind = kind;
  s.identifier = mercator ? kGoogleMapsCompatible : kWorldCrs84Quad;
  s.crs = mercator ? kEpsg3857 : kCrs84;
  s.wellKnownScaleSet = mercator ? "urn:ogc:def:wkss:OGC:1.0:GoogleMapsCompatible"
                                 : "http://www.opengis.net/def/wkss/OGC/1.0/GoogleCRS84Quad";
  Sector box = coverage;
  if (mercator) {
    box = Sector{coverage.west * kWebMercatorHalf / 180.0,
                 mercatorY(coverage.south),
                 coverage.east * kWebMercatorHalf / 180.0,
                 mercatorY(coverage.north)};
  }
  for (std::int32_t z = 0; z < levels; ++z) {
    WmtsTileMatrix m;
    m.identifier = std::to_string(z);
    m.tileWidth = m.tileHeight = 256;
    if (mercator) {
      m.left = -kWebMercatorHalf;
      m.top = kWebMercatorHalf;
      m.tileSpan = std::ldexp(2 * kWebMercatorHalf, -z);
      m.matrixWidth = m.matrixHeight = std::int64_t{1} << z;
      m.scaleDenominator = m.tileSpan / 256 / kPixelMetres;
    } else {
      m.left = -180.0;
      m.top = 90.0;
      m.tileSpan = std::ldexp(180.0, -z);
      m.matrixWidth = std::int64_t{2} << z;
      m.matrixHeight = std::int64_t{1} << z;
      m.scaleDenominator = m.tileSpan / 256 * kMetresPerDegree / kPixelMetres;
    }
    limitTo(m, box);
    s.matrices.push_back(std::move(m));
  }
  return s;
}

Sector wmtsTileBox(const WmtsTileMatrix& m, std::int64_t row, std::int64_t col) {
  // Edges from integer indices (spans are powers of two of the level-zero span): neighbours share
  // them exactly.
  const auto x = [&](std::int64_t c) { return m.left + static_cast<double>(c) * m.tileSpan; };
  const auto y = [&](std::int64_t r) { return m.top - static_cast<double>(r) * m.tileSpan; };
  return Sector{x(col), y(row + 1), x(col + 1), y(row)};
}

TileKey worldWindKeyOf(const WmtsTileMatrixSet& set,
                       std::size_t matrix,
                       std::int64_t row,
                       std::int64_t col) {
  const WmtsTileMatrix& m = set.matrices[matrix];
  return TileKey{set.firstLevel + static_cast<std::int32_t>(matrix), m.matrixHeight - 1 - row, col};
}

TileKey crs84QuadCacheKey(std::int32_t level, std::int64_t row, std::int64_t col) {
  return TileKey{level, (std::int64_t{1} << level) - 1 - row, col};
}

GridSpec composedCacheGrid(WmtsSetKind kind, std::int32_t levels) {
  const Sector world{};
  const Sector west{-180.0, -90.0, 0.0, 90.0};
  return GridSpec{
      kind == WmtsSetKind::GoogleMapsCompatible ? west : world, 180.0, 256, 256, levels};
}

std::expected<std::size_t, OgcException> checkWmtsTile(const WmtsTileMatrixSet& set,
                                                       std::string_view id,
                                                       std::int64_t row,
                                                       std::int64_t col) {
  for (std::size_t i = 0; i < set.matrices.size(); ++i) {
    const WmtsTileMatrix& m = set.matrices[i];
    if (m.identifier != id) continue;
    if (row < m.minRow || row > m.maxRow)
      return std::unexpected(err(ogc::kTileOutOfRange,
                                 "TileRow",
                                 "TileRow " + std::to_string(row) + " is outside " +
                                     std::to_string(m.minRow) + ".." + std::to_string(m.maxRow)));
    if (col < m.minCol || col > m.maxCol)
      return std::unexpected(err(ogc::kTileOutOfRange,
                                 "TileCol",
                                 "TileCol " + std::to_string(col) + " is outside " +
                                     std::to_string(m.minCol) + ".." + std::to_string(m.maxCol)));
    return i;
  }
  return std::unexpected(
      err(ogc::kInvalidParameterValue,
          "TileMatrix",
          "no tile matrix '" + std::string(id.substr(0, 64)) + "' in " + set.identifier));
}

// ---- requests -----------------------------------------------------------------------------------

std::expected<WmtsRequest, OgcException> parseWmtsKvp(const QueryParams& params) {
  const auto service = params.get("service");
  if (!service || service->empty())
    return std::unexpected(err(ogc::kMissingParameterValue, "SERVICE", "SERVICE is missing"));
  if (!iequals(*service, "WMTS"))
    return std::unexpected(err(ogc::kInvalidParameterValue, "SERVICE", "SERVICE must be WMTS"));
  const auto request = params.get("request");
  if (!request || request->empty())
    return std::unexpected(err(ogc::kMissingParameterValue, "REQUEST", "REQUEST is missing"));
  if (iequals(*request, "GetCapabilities")) {
    if (const auto av = params.get("acceptversions")) {
      bool ok = false;
      std::string_view rest = *av;
      while (!ok) {
        const auto comma = rest.find(',');
        ok = rest.substr(0, comma) == "1.0.0";
        if (comma == std::string_view::npos) break;
        rest.remove_prefix(comma + 1);
      }
      if (!ok)
        return std::unexpected(err(
            "VersionNegotiationFailed", "AcceptVersions", "this server speaks WMTS 1.0.0 only"));
    }
    return WmtsGetCapabilitiesRequest{};
  }
  if (!iequals(*request, "GetTile"))
    return std::unexpected(
        err(ogc::kOperationNotSupported, "REQUEST", "REQUEST must be GetCapabilities or GetTile"));
  for (const std::string_view k : {"version",
                                   "layer",
                                   "style",
                                   "format",
                                   "tilematrixset",
                                   "tilematrix",
                                   "tilerow",
                                   "tilecol",
                                   "time"}) {
    if (params.isConflicting(k))
      return std::unexpected(
          err(ogc::kInvalidParameterValue, k, std::string(k) + " is given twice"));
  }
  const auto version = params.get("version");
  if (!version || version->empty())
    return std::unexpected(err(ogc::kMissingParameterValue, "VERSION", "VERSION is missing"));
  if (*version != "1.0.0")
    return std::unexpected(err(ogc::kInvalidParameterValue, "VERSION", "VERSION must be 1.0.0"));
  WmtsGetTileRequest t;
  struct Field {
    std::string_view key, locator;
    std::string* into;
    bool mayBeEmpty;
  };
  std::string row, col;
  for (const Field& f : {Field{"layer", "LAYER", &t.layer, false},
                         Field{"style", "STYLE", &t.style, true},
                         Field{"format", "FORMAT", &t.format, false},
                         Field{"tilematrixset", "TILEMATRIXSET", &t.tileMatrixSet, false},
                         Field{"tilematrix", "TILEMATRIX", &t.tileMatrix, false},
                         Field{"tilerow", "TILEROW", &row, false},
                         Field{"tilecol", "TILECOL", &col, false}}) {
    const auto v = params.get(f.key);
    if (!v || (v->empty() && !f.mayBeEmpty))
      return std::unexpected(
          err(ogc::kMissingParameterValue, f.locator, std::string(f.locator) + " is missing"));
    *f.into = *v;
  }
  const auto r = wholeNumber(row);
  if (!r)
    return std::unexpected(
        err(ogc::kInvalidParameterValue, "TILEROW", "TILEROW must be a whole number >= 0"));
  const auto c = wholeNumber(col);
  if (!c)
    return std::unexpected(
        err(ogc::kInvalidParameterValue, "TILECOL", "TILECOL must be a whole number >= 0"));
  t.row = *r;
  t.col = *c;
  if (const auto time = params.get("time")) t.time = std::string(*time);
  return t;
}

std::expected<WmtsRequest, OgcException> parseWmtsRest(std::string_view path) {
  if (path == "WMTSCapabilities.xml") return WmtsGetCapabilitiesRequest{};
  std::vector<std::string> parts;
  while (true) {
    const auto slash = path.find('/');
    auto decoded = percentDecode(path.substr(0, slash), false);
    if (!decoded || decoded->empty())
      return std::unexpected(
          err(ogc::kInvalidParameterValue, "", "not a WMTS resource: an empty or bad segment"));
    parts.push_back(std::move(*decoded));
    if (slash == std::string_view::npos) break;
    path.remove_prefix(slash + 1);
    if (parts.size() > 7) break;
  }
  if (parts.size() != 6 && parts.size() != 7)
    return std::unexpected(err(ogc::kInvalidParameterValue,
                               "",
                               "not a WMTS resource: "
                               "<layer>/<style>/[<time>/]<set>/<matrix>/<row>/<col>.<ext>"));
  WmtsGetTileRequest t;
  std::size_t i = 0;
  t.layer = parts[i++];
  t.style = parts[i++];
  if (parts.size() == 7) t.time = parts[i++];
  t.tileMatrixSet = parts[i++];
  t.tileMatrix = parts[i++];
  const auto r = wholeNumber(parts[i++]);
  std::string_view last = parts[i];
  const auto dot = last.rfind('.');
  const auto c = dot == std::string_view::npos ? std::nullopt : wholeNumber(last.substr(0, dot));
  if (!r)
    return std::unexpected(
        err(ogc::kInvalidParameterValue, "TileRow", "TileRow must be a whole number >= 0"));
  if (!c || dot + 1 >= last.size())
    return std::unexpected(
        err(ogc::kInvalidParameterValue, "TileCol", "expected <col>.<ext> with a whole number"));
  t.row = *r;
  t.col = *c;
  t.extension = std::string(last.substr(dot + 1));
  return t;
}

int wmtsExceptionHttpStatus(std::string_view code) noexcept {
  if (code == ogc::kOperationNotSupported) return 501;
  if (code == ogc::kMissingParameterValue || code == ogc::kInvalidParameterValue ||
      code == ogc::kTileOutOfRange || code == "VersionNegotiationFailed" ||
      code == ogc::kInvalidUpdateSequence)
    return 400;
  return 500;
}

} // namespace tellus
