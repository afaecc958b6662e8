// WMTS 1.0.0 requests (KVP and RESTful) and the tile matrix sets' arithmetic (Wmts.hpp).
#include <tellus/proxy/Wmts.hpp>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstring>
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

namespace {

/** The KVP parameters a WMTS request reads, by their index in kKvpNames (in the order in which
 * parseKvpValues checks them for conflicts: VERSION..TIME). */
namespace KvpKey {
enum : std::size_t {
  Service,
  Request,
  AcceptVersions,
  Version,
  Layer,
  Style,
  Format,
  TileMatrixSet,
  TileMatrix,
  TileRow,
  TileCol,
  Time,
  Count
};
}
constexpr std::array<std::string_view, KvpKey::Count> kKvpNames{"service",
                                                                "request",
                                                                "acceptversions",
                                                                "version",
                                                                "layer",
                                                                "style",
                                                                "format",
                                                                "tilematrixset",
                                                                "tilematrix",
                                                                "tilerow",
                                                                "tilecol",
                                                                "time"};

/** The index in kKvpNames of a parameter's name (ASCII case-insensitive), or KvpKey::Count. */
std::size_t kvpIndex(std::string_view name) noexcept {
  // Every name is lower-case letters: (c | 0x20) is c lower-cased exactly when it can match. The
  // names are 4 to 14 bytes long: compared as two overlapping words.
  const auto is = [name](std::size_t key) {
    const std::string_view k = kKvpNames[key];
    const auto word = [](std::string_view s, std::size_t at, std::size_t n) {
      std::uint64_t w = 0;
      std::memcpy(&w, s.data() + at, n);
      return w;
    };
    const std::size_t n = k.size() < 8 ? 4 : 8;
    const std::uint64_t caseBits = n == 8 ? 0x2020202020202020u : 0x20202020u;
    return ((word(name, 0, n) | caseBits) == word(k, 0, n)) &&
           ((word(name, k.size() - n, n) | caseBits) == word(k, k.size() - n, n));
  };
  switch (name.size()) { // the names of each length, in kKvpNames's order
  case 4:
    return is(KvpKey::Time) ? KvpKey::Time : KvpKey::Count;
  case 5:
    return is(KvpKey::Layer) ? KvpKey::Layer : is(KvpKey::Style) ? KvpKey::Style : KvpKey::Count;
  case 6:
    return is(KvpKey::Format) ? KvpKey::Format : KvpKey::Count;
  case 7:
    for (const std::size_t key :
         {KvpKey::Service, KvpKey::Request, KvpKey::Version, KvpKey::TileRow, KvpKey::TileCol})
      if (is(key)) return key;
    return KvpKey::Count;
  case 10:
    return is(KvpKey::TileMatrix) ? KvpKey::TileMatrix : KvpKey::Count;
  case 13:
    return is(KvpKey::TileMatrixSet) ? KvpKey::TileMatrixSet : KvpKey::Count;
  case 14:
    return is(KvpKey::AcceptVersions) ? KvpKey::AcceptVersions : KvpKey::Count;
  default:
    return KvpKey::Count;
  }
}

/** The values (first occurrence) and conflicts of the parameters of kKvpNames. */
struct KvpValues {
  std::array<std::optional<std::string_view>, KvpKey::Count> values;
  std::array<bool, KvpKey::Count> conflicting{};
  std::optional<std::string_view> get(std::size_t key) const noexcept { return values[key]; }
};

std::expected<WmtsRequest, OgcException> parseKvpValues(const KvpValues& params) {
  const auto service = params.get(KvpKey::Service);
  if (!service || service->empty())
    return std::unexpected(err(ogc::kMissingParameterValue, "SERVICE", "SERVICE is missing"));
  if (!iequals(*service, "WMTS"))
    return std::unexpected(err(ogc::kInvalidParameterValue, "SERVICE", "SERVICE must be WMTS"));
  const auto request = params.get(KvpKey::Request);
  if (!request || request->empty())
    return std::unexpected(err(ogc::kMissingParameterValue, "REQUEST", "REQUEST is missing"));
  if (iequals(*request, "GetCapabilities")) {
    if (const auto av = params.get(KvpKey::AcceptVersions)) {
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
  for (std::size_t i = KvpKey::Version; i <= KvpKey::Time; ++i) {
    const std::string_view k = kKvpNames[i];
    if (params.conflicting[i])
      return std::unexpected(
          err(ogc::kInvalidParameterValue, k, std::string(k) + " is given twice"));
  }
  const auto version = params.get(KvpKey::Version);
  if (!version || version->empty())
    return std::unexpected(err(ogc::kMissingParameterValue, "VERSION", "VERSION is missing"));
  if (*version != "1.0.0")
    return std::unexpected(err(ogc::kInvalidParameterValue, "VERSION", "VERSION must be 1.0.0"));
  WmtsGetTileRequest t;
  struct Field {
    std::size_t key;
    std::string_view locator;
    std::string* into;
    bool mayBeEmpty;
  };
  std::string row, col;
  for (const Field& f : {Field{KvpKey::Layer, "LAYER", &t.layer, false},
                         Field{KvpKey::Style, "STYLE", &t.style, true},
                         Field{KvpKey::Format, "FORMAT", &t.format, false},
                         Field{KvpKey::TileMatrixSet, "TILEMATRIXSET", &t.tileMatrixSet, false},
                         Field{KvpKey::TileMatrix, "TILEMATRIX", &t.tileMatrix, false},
                         Field{KvpKey::TileRow, "TILEROW", &row, false},
                         Field{KvpKey::TileCol, "TILECOL", &col, false}}) {
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
  if (const auto time = params.get(KvpKey::Time)) t.time = std::string(*time);
  return t;
}

} // namespace

std::expected<WmtsRequest, OgcException> parseWmtsKvp(const QueryParams& params) {
  KvpValues v;
  for (const QueryParams::Entry& e : params.entries()) { // one entry per name (lower-case)
    const std::size_t i = kvpIndex(e.key);
    if (i == KvpKey::Count) continue;
    v.values[i] = std::string_view(e.value);
    v.conflicting[i] = e.conflicting;
  }
  return parseKvpValues(v);
}

std::optional<std::expected<WmtsRequest, OgcException>>
parseWmtsKvpQuery(std::string_view query, std::size_t maxParamBytes, std::size_t maxQueryBytes) {
  // What parseQuery would refuse or decode (and a name given twice) is left to it.
  if (query.size() > maxQueryBytes) return std::nullopt;
  if (!query.empty() && query.front() == '?') query.remove_prefix(1);
  for (const char c : {'%', '+', '\0'}) // decoded by parseQuery
    if (query.find(c) != std::string_view::npos) return std::nullopt;
  KvpValues v;
  std::size_t count = 0;
  std::size_t offset = 0;
  while (offset <= query.size()) {
    const std::size_t amp = query.find('&', offset);
    const std::size_t end = amp == std::string_view::npos ? query.size() : amp;
    const std::string_view segment = query.substr(offset, end - offset);
    offset = end + 1;
    if (segment.empty()) continue;
    if (++count > kMaxQueryParams) return std::nullopt;
    const std::size_t eq = segment.find('=');
    const std::string_view key = segment.substr(0, eq);
    const std::string_view value =
        eq == std::string_view::npos ? std::string_view{} : segment.substr(eq + 1);
    if (key.size() > maxParamBytes || value.size() > maxParamBytes) return std::nullopt;
    const std::size_t k = kvpIndex(key);
    if (k == KvpKey::Count) continue;
    if (v.values[k]) return std::nullopt; // given twice: parseQuery tells repeats from conflicts
    v.values[k] = value;
  }
  return parseKvpValues(v);
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
