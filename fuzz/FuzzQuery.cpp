// libFuzzer target: a URL query string as a client sends it, through everything the WMS and World
// Wind front ends do with it before touching the cache: parseQuery, parseWms, wmsErrorContext,
// parseWorldWindTile, parseWmtsKvp and parseWmtsKvpQuery (WMTS, the two agree), checkUpdateSequence
// and xmlEscape (what error bodies quote). Besides the sanitizers, every documented property of a
// successful parse is checked; a violation traps.

#include "FuzzCheck.hpp"

#include <tellus/proxy/Query.hpp>
#include <tellus/proxy/Wms.hpp>
#include <tellus/proxy/Wmts.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <variant>

namespace {

using namespace tellus;

bool isKnownOgcCode(std::string_view code) {
  for (const std::string_view c : {ogc::kLayerNotDefined,
                                   ogc::kInvalidCrs,
                                   ogc::kInvalidSrs,
                                   ogc::kInvalidFormat,
                                   ogc::kStyleNotDefined,
                                   ogc::kLayerNotQueryable,
                                   ogc::kInvalidPoint,
                                   ogc::kMissingDimensionValue,
                                   ogc::kInvalidDimensionValue,
                                   ogc::kOperationNotSupported,
                                   ogc::kMissingParameterValue,
                                   ogc::kInvalidParameterValue,
                                   ogc::kInvalidUpdateSequence,
                                   ogc::kCurrentUpdateSequence,
                                   ogc::kNoApplicableCode}) {
    if (code == c) return true;
  }
  return false;
}

void checkParams(const QueryParams& params, std::size_t maxParamBytes) {
  TELLUS_FUZZ_CHECK(params.size() <= kMaxQueryParams);
  for (const auto& e : params.entries()) {
    TELLUS_FUZZ_CHECK(!e.key.empty() && e.key.size() <= maxParamBytes);
    TELLUS_FUZZ_CHECK(e.value.size() <= maxParamBytes);
    TELLUS_FUZZ_CHECK(e.occurrences >= 1);
    for (const char c : e.key)
      TELLUS_FUZZ_CHECK(c != '\0' && !(c >= 'A' && c <= 'Z'));
    TELLUS_FUZZ_CHECK(e.value.find('\0') == std::string::npos);
    // The first occurrence wins, and lookups are case-insensitive.
    const auto v = params.get(e.key);
    TELLUS_FUZZ_CHECK(v && *v == e.value);
    TELLUS_FUZZ_CHECK(params.isDuplicated(e.key) == (e.occurrences > 1));
  }
}

void checkGetMap(const GetMapRequest& m, const WmsLimits& limits) {
  const Sector& b = m.bbox;
  TELLUS_FUZZ_CHECK(std::isfinite(b.west) && std::isfinite(b.south) && std::isfinite(b.east) &&
                    std::isfinite(b.north));
  TELLUS_FUZZ_CHECK(b.west < b.east && b.south < b.north);
  const bool mercator = m.crs == kWebMercator; // the bbox in metres
  for (const double v : {b.west, b.south, b.east, b.north}) {
    TELLUS_FUZZ_CHECK(std::fabs(v) <= (mercator ? kMaxBboxMagnitudeMetres : kMaxBboxMagnitudeDeg));
    TELLUS_FUZZ_CHECK(!(v == 0.0 && std::signbit(v))); // -0 is normalised to 0
  }
  TELLUS_FUZZ_CHECK(m.width >= 1 && m.width <= limits.maxWidth);
  TELLUS_FUZZ_CHECK(m.height >= 1 && m.height <= limits.maxHeight);
  TELLUS_FUZZ_CHECK(!m.layers.empty() && m.styles.size() == m.layers.size());
  for (const auto& l : m.layers)
    TELLUS_FUZZ_CHECK(!l.empty());
  TELLUS_FUZZ_CHECK(m.crs == "EPSG:4326" || m.crs == "CRS:84" || mercator);
  // The map's box: finite longitudes in order, latitudes inside the Mercator square's.
  const MapBox box = mapBoxOf(m);
  TELLUS_FUZZ_CHECK(std::isfinite(box.west) && std::isfinite(box.east) && box.west <= box.east);
  TELLUS_FUZZ_CHECK(!mercator ||
                    (box.south <= box.north && box.north <= 90.0 && box.rows == MapRows::Mercator));
  TELLUS_FUZZ_CHECK(!m.format.empty());
  TELLUS_FUZZ_CHECK(!m.bgcolor || *m.bgcolor <= 0xFFFFFFu);
}

// xmlEscape must give well-formed character data: no markup characters, no control characters but
// TAB and LF, every '&' an entity, and valid UTF-8 without surrogates, U+FFFE or U+FFFF.
void checkXmlEscaped(std::string_view s) {
  std::size_t i = 0;
  while (i < s.size()) {
    const auto b = static_cast<unsigned char>(s[i]);
    TELLUS_FUZZ_CHECK(b != '<' && b != '>' && b != '"' && b != '\'');
    TELLUS_FUZZ_CHECK(b >= 0x20 || b == '\t' || b == '\n');
    TELLUS_FUZZ_CHECK(b != 0x7F);
    if (b == '&') {
      const std::string_view rest = s.substr(i);
      bool entity = false;
      for (const std::string_view e : {"&amp;", "&lt;", "&gt;", "&quot;", "&apos;", "&#13;"}) {
        if (rest.starts_with(e)) {
          i += e.size();
          entity = true;
          break;
        }
      }
      TELLUS_FUZZ_CHECK(entity);
      continue;
    }
    if (b < 0x80) {
      ++i;
      continue;
    }
    std::size_t len = 0;
    std::uint32_t cp = 0;
    if (b >= 0xC2 && b <= 0xDF) {
      len = 2;
      cp = b & 0x1Fu;
    } else if (b >= 0xE0 && b <= 0xEF) {
      len = 3;
      cp = b & 0x0Fu;
    } else if (b >= 0xF0 && b <= 0xF4) {
      len = 4;
      cp = b & 0x07u;
    }
    TELLUS_FUZZ_CHECK(len != 0 && i + len <= s.size());
    for (std::size_t k = 1; k < len; ++k) {
      const auto c = static_cast<unsigned char>(s[i + k]);
      TELLUS_FUZZ_CHECK((c & 0xC0u) == 0x80u);
      cp = (cp << 6) | (c & 0x3Fu);
    }
    const std::uint32_t minCp = len == 2 ? 0x80u : len == 3 ? 0x800u : 0x10000u;
    TELLUS_FUZZ_CHECK(cp >= minCp && cp <= 0x10FFFFu);
    TELLUS_FUZZ_CHECK(!(cp >= 0xD800u && cp <= 0xDFFFu) && cp != 0xFFFEu && cp != 0xFFFFu);
    i += len;
  }
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);

  checkXmlEscaped(xmlEscape(input));
  for (const bool plus : {true, false}) {
    const auto decoded = percentDecode(input, plus);
    if (decoded) {
      TELLUS_FUZZ_CHECK(decoded->size() <= input.size());
      TELLUS_FUZZ_CHECK(decoded->find('\0') == std::string::npos);
    } else {
      TELLUS_FUZZ_CHECK(!decoded.error().empty());
    }
  }

  // The server's defaults, and small limits so that the limit branches are reached too.
  constexpr std::size_t kSmallParamBytes = 16;
  const auto small = parseQuery(input, kSmallParamBytes, 256);
  if (small) checkParams(*small, kSmallParamBytes);

  // The WMTS front end's one-pass parse: where it answers, the general path's answer.
  for (const auto& [paramBytes, queryBytes] :
       {std::pair<std::size_t, std::size_t>{kSmallParamBytes, 256}, {2048, 16384}}) {
    const auto quick = parseWmtsKvpQuery(input, paramBytes, queryBytes);
    if (!quick) continue;
    const auto general = paramBytes == kSmallParamBytes ? small : parseQuery(input);
    TELLUS_FUZZ_CHECK(general.has_value());
    const auto expected = parseWmtsKvp(*general);
    TELLUS_FUZZ_CHECK(quick->has_value() == expected.has_value());
    if (expected) {
      TELLUS_FUZZ_CHECK(**quick == *expected);
    } else {
      TELLUS_FUZZ_CHECK(quick->error().code == expected.error().code &&
                        quick->error().locator == expected.error().locator &&
                        quick->error().message == expected.error().message);
    }
  }

  const auto params = parseQuery(input);
  if (!params) {
    TELLUS_FUZZ_CHECK(!params.error().empty());
    return 0;
  }
  checkParams(*params, 2048);

  if (const auto wmts = parseWmtsKvp(*params)) {
    if (const auto* t = std::get_if<WmtsGetTileRequest>(&*wmts)) {
      TELLUS_FUZZ_CHECK(!t->layer.empty() && !t->format.empty() && !t->tileMatrixSet.empty() &&
                        !t->tileMatrix.empty());
      TELLUS_FUZZ_CHECK(t->row >= 0 && t->col >= 0 && t->extension.empty());
    }
  } else {
    const OgcException& e = wmts.error();
    TELLUS_FUZZ_CHECK(isKnownOgcCode(e.code) || e.code == "VersionNegotiationFailed");
    TELLUS_FUZZ_CHECK(!e.message.empty());
    TELLUS_FUZZ_CHECK(wmtsExceptionHttpStatus(e.code) >= 400);
  }

  for (const WmsLimits limits : {WmsLimits{}, WmsLimits{256, 64}}) {
    const auto request = parseWms(*params, limits);
    const WmsErrorContext ctx = wmsErrorContext(*params, limits);
    if (ctx.exceptions != GetMapRequest::Exceptions::Xml) {
      TELLUS_FUZZ_CHECK(!ctx.format.empty());
      TELLUS_FUZZ_CHECK(ctx.width >= 1 && ctx.width <= limits.maxWidth);
      TELLUS_FUZZ_CHECK(ctx.height >= 1 && ctx.height <= limits.maxHeight);
      TELLUS_FUZZ_CHECK(!ctx.bgcolor || *ctx.bgcolor <= 0xFFFFFFu);
    }
    if (!request) {
      const OgcException& e = request.error();
      TELLUS_FUZZ_CHECK(isKnownOgcCode(e.code));
      TELLUS_FUZZ_CHECK(!e.message.empty());
      checkXmlEscaped(xmlEscape(e.message));
      continue;
    }
    if (const auto* m = std::get_if<GetMapRequest>(&*request)) {
      checkGetMap(*m, limits);
      // A GetMap that parses reports its errors the way it asked for them.
      TELLUS_FUZZ_CHECK(ctx.version == m->version);
      TELLUS_FUZZ_CHECK(ctx.exceptions == m->exceptions);
      if (m->exceptions != GetMapRequest::Exceptions::Xml) {
        TELLUS_FUZZ_CHECK(ctx.format == m->format && ctx.width == m->width &&
                          ctx.height == m->height && ctx.transparent == m->transparent &&
                          ctx.bgcolor == m->bgcolor);
      }
    } else if (const auto* f = std::get_if<GetFeatureInfoRequest>(&*request)) {
      // GetFeatureInfo (issue 24): its map is a GetMap that parses, the point lies on it.
      checkGetMap(f->map, limits);
      TELLUS_FUZZ_CHECK(f->i >= 0 && f->i < f->map.width && f->j >= 0 && f->j < f->map.height);
      TELLUS_FUZZ_CHECK(!f->queryLayers.empty() && f->featureCount >= 1);
      for (const std::string& q : f->queryLayers)
        TELLUS_FUZZ_CHECK(std::find(f->map.layers.begin(), f->map.layers.end(), q) !=
                          f->map.layers.end());
    } else if (const auto* g = std::get_if<GetLegendGraphicRequest>(&*request)) {
      TELLUS_FUZZ_CHECK(!g->layer.empty());
      TELLUS_FUZZ_CHECK(g->width == 0 || (g->width >= 32 && g->width <= 4096));
      TELLUS_FUZZ_CHECK(g->height == 0 || (g->height >= 32 && g->height <= 4096));
    } else {
      const auto& caps = std::get<GetCapabilitiesRequest>(*request);
      const auto e = checkUpdateSequence(caps.updateSequence, "2024-06-01T00:00:00Z");
      TELLUS_FUZZ_CHECK(!e || e->code == ogc::kCurrentUpdateSequence ||
                        e->code == ogc::kInvalidUpdateSequence);
      const auto n = checkUpdateSequence(caps.updateSequence, "00120");
      TELLUS_FUZZ_CHECK(!n || n->code == ogc::kCurrentUpdateSequence ||
                        n->code == ogc::kInvalidUpdateSequence);
    }
  }

  const auto tile = parseWorldWindTile(*params);
  if (tile) {
    TELLUS_FUZZ_CHECK(!tile->dataset.empty());
    TELLUS_FUZZ_CHECK(tile->level >= 0 && tile->level <= kMaxLevel);
    TELLUS_FUZZ_CHECK(tile->col >= 0 && tile->row >= 0);
  } else {
    TELLUS_FUZZ_CHECK(!tile.error().empty());
  }
  return 0;
}
