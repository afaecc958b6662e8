// A WMTS 1.0.0 Capabilities document read into WmtsCapabilities (WmtsUpstream.hpp).

#include "MiniXml.hpp"

#include <tellus/proxy/WmtsUpstream.hpp>

#include <charconv>
#include <cmath>
#include <string>

namespace tellus {

namespace {

std::optional<double> number(std::string_view s) {
  s = xml::trim(s);
  double v = 0.0;
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || p != s.data() + s.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::optional<std::int64_t> integer(std::string_view s) {
  s = xml::trim(s);
  std::int64_t v = 0;
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || p != s.data() + s.size()) return std::nullopt;
  return v;
}

std::expected<UpstreamTileMatrix, std::string> readMatrix(const xml::Element& m,
                                                          const std::string& set) {
  UpstreamTileMatrix t;
  t.identifier = m.childText("Identifier");
  const std::string where = "tile matrix '" + t.identifier + "' of set '" + set + "'";
  if (t.identifier.empty())
    return std::unexpected("a tile matrix of set '" + set + "' has no Identifier");
  const auto sd = number(m.childText("ScaleDenominator"));
  if (!sd || *sd <= 0.0) return std::unexpected(where + ": no positive ScaleDenominator");
  t.scaleDenominator = *sd;
  const std::string corner = m.childText("TopLeftCorner");
  const std::size_t sp = corner.find_first_of(" \t\r\n");
  const auto x = sp == std::string::npos ? std::nullopt : number(corner.substr(0, sp));
  const auto y = sp == std::string::npos ? std::nullopt : number(corner.substr(sp));
  if (!x || !y)
    return std::unexpected(where + ": TopLeftCorner '" + corner + "' is not two numbers");
  t.topLeftX = *x;
  t.topLeftY = *y;
  const auto tw = integer(m.childText("TileWidth"));
  const auto th = integer(m.childText("TileHeight"));
  const auto mw = integer(m.childText("MatrixWidth"));
  const auto mh = integer(m.childText("MatrixHeight"));
  if (!tw || !th || *tw < 1 || *th < 1 || *tw > 65536 || *th > 65536)
    return std::unexpected(where +
                           ": TileWidth and TileHeight must be whole numbers in [1, 65536]");
  if (!mw || !mh || *mw < 1 || *mh < 1 || *mw > (1LL << 40) || *mh > (1LL << 40))
    return std::unexpected(where + ": MatrixWidth and MatrixHeight must be positive whole numbers");
  t.tileWidth = static_cast<std::int32_t>(*tw);
  t.tileHeight = static_cast<std::int32_t>(*th);
  t.matrixWidth = *mw;
  t.matrixHeight = *mh;
  return t;
}

WmtsLayer readLayer(const xml::Element& l) {
  WmtsLayer out;
  out.identifier = l.childText("Identifier");
  out.title = l.childText("Title");
  for (const xml::Element* s : l.all("Style")) {
    std::string id = s->childText("Identifier");
    const std::string* def = s->attribute("isDefault");
    if (def && xml::trim(*def) == "true")
      out.styles.insert(out.styles.begin(), std::move(id));
    else
      out.styles.push_back(std::move(id));
  }
  for (const xml::Element* f : l.all("Format"))
    out.formats.emplace_back(xml::trim(f->text));
  for (const xml::Element* link : l.all("TileMatrixSetLink"))
    out.tileMatrixSets.push_back(link->childText("TileMatrixSet"));
  for (const xml::Element* d : l.all("Dimension")) {
    WmtsDimension dim;
    dim.identifier = d->childText("Identifier");
    dim.defaultValue = d->childText("Default");
    for (const xml::Element* v : d->all("Value"))
      dim.values.emplace_back(xml::trim(v->text));
    out.dimensions.push_back(std::move(dim));
  }
  for (const xml::Element* r : l.all("ResourceURL")) {
    WmtsResourceUrl u;
    if (const auto* a = r->attribute("format")) u.format = *a;
    if (const auto* a = r->attribute("resourceType")) u.resourceType = *a;
    if (const auto* a = r->attribute("template")) u.tmpl = *a;
    out.resourceUrls.push_back(std::move(u));
  }
  return out;
}

/** OperationsMetadata / Operation name=GetTile / DCP / HTTP / Get with a KVP constraint (or, when
 * no Get says which encoding it is, the first one). */
std::string kvpGetTileUrl(const xml::Element& root) {
  const xml::Element* ops = root.child("OperationsMetadata");
  if (!ops) return {};
  for (const xml::Element* op : ops->all("Operation")) {
    const std::string* name = op->attribute("name");
    if (!name || *name != "GetTile") continue;
    std::string fallback;
    for (const xml::Element* dcp : op->all("DCP"))
      for (const xml::Element* http : dcp->all("HTTP"))
        for (const xml::Element* get : http->all("Get")) {
          const std::string* href = get->attribute("href");
          if (!href) continue;
          bool sawEncoding = false;
          for (const xml::Element* c : get->all("Constraint")) {
            const xml::Element* allowed = c->child("AllowedValues");
            if (!allowed) continue;
            for (const xml::Element* v : allowed->all("Value")) {
              sawEncoding = true;
              if (xml::trim(v->text) == "KVP") return *href;
            }
          }
          if (!sawEncoding && fallback.empty()) fallback = *href;
        }
    return fallback;
  }
  return {};
}

} // namespace

const WmtsLayer* WmtsCapabilities::layer(std::string_view id) const noexcept {
  for (const auto& l : layers)
    if (l.identifier == id) return &l;
  return nullptr;
}

const UpstreamTileMatrixSet* WmtsCapabilities::tileMatrixSet(std::string_view id) const noexcept {
  for (const auto& s : tileMatrixSets)
    if (s.identifier == id) return &s;
  return nullptr;
}

std::expected<WmtsCapabilities, std::string> parseWmtsCapabilities(std::string_view text) {
  auto doc = xml::parse(text);
  if (!doc) return std::unexpected("not a WMTS capabilities document: " + doc.error());
  const xml::Element& root = **doc;
  if (root.local() == "ExceptionReport") {
    std::string why;
    for (const xml::Element* e : root.all("Exception"))
      why += (why.empty() ? "" : "; ") + e->childText("ExceptionText");
    return std::unexpected("the server answered an exception report: " + why);
  }
  if (root.local() != "Capabilities")
    return std::unexpected("not a WMTS capabilities document: the root element is <" + root.name +
                           ">, not <Capabilities>");
  WmtsCapabilities caps;
  if (const xml::Element* si = root.child("ServiceIdentification"))
    caps.title = si->childText("Title");
  caps.getTileKvpUrl = kvpGetTileUrl(root);
  const xml::Element* contents = root.child("Contents");
  if (!contents) return std::unexpected("the capabilities have no <Contents>");
  for (const xml::Element* l : contents->all("Layer")) {
    WmtsLayer layer = readLayer(*l);
    if (layer.identifier.empty()) return std::unexpected("a <Layer> has no ows:Identifier");
    caps.layers.push_back(std::move(layer));
  }
  for (const xml::Element* s : contents->all("TileMatrixSet")) {
    UpstreamTileMatrixSet set;
    set.identifier = s->childText("Identifier");
    if (set.identifier.empty()) return std::unexpected("a <TileMatrixSet> has no ows:Identifier");
    set.crs = s->childText("SupportedCRS");
    for (const xml::Element* m : s->all("TileMatrix")) {
      auto matrix = readMatrix(*m, set.identifier);
      if (!matrix) return std::unexpected(matrix.error());
      set.matrices.push_back(std::move(*matrix));
    }
    if (set.matrices.empty())
      return std::unexpected("tile matrix set '" + set.identifier + "' has no TileMatrix");
    caps.tileMatrixSets.push_back(std::move(set));
  }
  if (caps.layers.empty()) return std::unexpected("the capabilities list no layer");
  return caps;
}

} // namespace tellus
