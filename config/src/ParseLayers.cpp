// One entry of the configuration's layers: format, grid, elevation, time, cache
// (ParseSections.hpp).

#include "ParseSections.hpp"

namespace tellus::detail::yaml {

namespace {

/** The file suffix for a format ("" for an unknown one; validation reports it). */
std::string extensionFor(const std::string& format) {
  if (format == "image/jpeg") return "jpg";
  if (format == "image/png") return "png";
  if (format == "application/bil16") return "bil";
  if (format == "image/tiff") return "tif";
  return {};
}

void readGrid(Reader& r, const Map& layer, LayerConfig& l) {
  const auto [node, where] = layer.child("grid");
  if (node.IsNull()) layer.need("grid");
  const Map g(r,
              node,
              layer.path("grid"),
              where,
              {"sector", "level_zero_delta", "tile_size", "levels", "first_level"});
  GridSpec& spec = l.dataset.grid;
  if (auto v = g.get("sector")) {
    const std::string sp = g.path("sector");
    const auto items = list(r, *v, sp);
    if (items.size() != 4)
      r.fail(v->Mark(),
             sp,
             "expected 4 numbers [west, south, east, north], got " + std::to_string(items.size()));
    double e[4];
    for (std::size_t i = 0; i < 4; ++i) {
      const std::string ip = indexPath(sp, i);
      r.remember(ip, items[i].Mark());
      e[i] = number(r, items[i], ip);
    }
    spec.sector = Sector{e[0], e[1], e[2], e[3]};
  }
  if (auto v = g.get("level_zero_delta"))
    spec.levelZeroDeltaDeg = number(r, *v, g.path("level_zero_delta"));
  if (auto v = g.get("tile_size")) {
    const std::string tp = g.path("tile_size");
    if (v->IsSequence()) {
      const auto items = list(r, *v, tp);
      if (items.size() != 2)
        r.fail(v->Mark(),
               tp,
               "expected a size or [width, height], got " + std::to_string(items.size()) +
                   " numbers");
      spec.tileWidth = int32(r, items[0], indexPath(tp, 0));
      spec.tileHeight = int32(r, items[1], indexPath(tp, 1));
    } else {
      spec.tileWidth = spec.tileHeight = int32(r, *v, tp);
    }
  }
  spec.numLevels = int32(r, g.need("levels"), g.path("levels"));
  if (auto v = g.get("first_level")) l.firstLevel = int32(r, *v, g.path("first_level"));
}

void readTime(Reader& r, const Map& layer, TimeDimension& t) {
  const auto [node, where] = layer.child("time");
  if (node.IsNull()) return;
  const Map m(r, node, layer.path("time"), where, {"values", "period", "default"});
  const auto values = m.get("values");
  const auto period = m.get("period");
  if (values && period)
    r.fail(m.keyMark("period"), m.path("period"), "give either values or a period, not both");
  if (!values && !period)
    r.fail(m.mark(), m.path(), "a time dimension needs values (a list) or a period");
  if (values) {
    const std::string vp = m.path("values");
    const auto items = list(r, *values, vp);
    if (items.empty()) r.fail(values->Mark(), vp, "the list of values is empty");
    for (std::size_t i = 0; i < items.size(); ++i) {
      const std::string ip = indexPath(vp, i);
      r.remember(ip, items[i].Mark());
      t.values.push_back(text(r, items[i], ip));
    }
  } else {
    t.period = text(r, *period, m.path("period"));
    auto p = detail::parseTimePeriod(t.period, TimeDimension::kMaxExpandedValues);
    if (!p) r.fail(period->Mark(), m.path("period"), p.error());
    t.values = std::move(p->expanded);
  }
  if (auto v = m.get("default")) {
    t.defaultValue = text(r, *v, m.path("default"));
  } else if (!t.values.empty()) {
    t.defaultValue = t.values.back();
  } else {
    const auto first = t.period.find('/');
    t.defaultValue = t.period.substr(first + 1, t.period.find('/', first + 1) - first - 1);
  }
}

/** layers[i].elevation: how an elevation layer's samples become metres. */
void readElevation(Reader& r, const Map& m, LayerConfig& l) {
  if (l.kind != LayerKind::Elevation)
    r.fail(m.keyMark("elevation"),
           m.path("elevation"),
           "'elevation' applies to elevation layers only (kind: elevation)");
  const auto [en, ewhere] = m.child("elevation");
  const Map e(r, en, m.path("elevation"), ewhere, {"encoding", "scale", "offset", "no_data"});
  if (auto v = e.get("encoding")) {
    switch (choice(r, *v, e.path("encoding"), {"bil16", "int16-tiff", "png16"})) {
    case 0:
      l.elevation.encoding = ElevationEncoding::Bil16;
      break;
    case 1:
      l.elevation.encoding = ElevationEncoding::Int16Tiff;
      break;
    default:
      l.elevation.encoding = ElevationEncoding::Png16;
      break;
    }
  }
  if (auto v = e.get("scale")) l.elevation.scale = number(r, *v, e.path("scale"));
  if (auto v = e.get("offset")) l.elevation.offset = number(r, *v, e.path("offset"));
  if (auto v = e.get("no_data")) l.elevation.noData = number(r, *v, e.path("no_data"));
}

/** layers[i].cache: ttl, pinned, max_age (whole seconds). */
void readLayerCache(Reader& r, const Map& m, LayerConfig& l) {
  const auto [cn, cwhere] = m.child("cache");
  const Map cm(r, cn, m.path("cache"), cwhere, {"ttl", "pinned", "max_age"});
  if (auto v = cm.get("ttl")) l.ttl = duration(r, *v, cm.path("ttl"));
  if (auto v = cm.get("pinned")) l.dataset.pinned = boolean(r, *v, cm.path("pinned"));
  if (auto v = cm.get("max_age")) {
    const auto d = duration(r, *v, cm.path("max_age"));
    if (d.count() % 1000 != 0)
      r.fail(v->Mark(),
             cm.path("max_age"),
             "max_age must be whole seconds, got '" + v->Scalar() + "'");
    l.maxAge = std::chrono::duration_cast<std::chrono::seconds>(d);
  }
}

} // namespace

LayerConfig readLayer(Reader& r, const YAML::Node& node, std::string path) {
  const Map m(r,
              node,
              std::move(path),
              node.Mark(),
              {"name",
               "title",
               "abstract",
               "upstream",
               "upstream_layer",
               "style",
               "format",
               "kind",
               "grid",
               "elevation",
               "values",
               "time",
               "cache",
               "opacity",
               "tile_matrix_set",
               "body"});
  if (node.IsNull())
    r.fail(node.Mark(), m.path(), "expected a mapping (name, upstream, ...), got nothing");
  LayerConfig l;
  l.name = text(r, m.need("name"), m.path("name"));
  l.title = l.name;
  if (auto v = m.get("title")) l.title = text(r, *v, m.path("title"));
  if (auto v = m.get("abstract")) l.abstract = text(r, *v, m.path("abstract"));
  l.upstream = text(r, m.need("upstream"), m.path("upstream"));
  l.upstreamLayer = l.name;
  if (auto v = m.get("upstream_layer")) l.upstreamLayer = text(r, *v, m.path("upstream_layer"));
  if (auto v = m.get("opacity")) {
    l.opacity = number(r, *v, m.path("opacity"));
    if (!(l.opacity >= 0.0 && l.opacity <= 1.0))
      r.fail(v->Mark(), m.path("opacity"), "an opacity is a number from 0 to 1");
  }
  if (auto v = m.get("style")) l.dataset.style = text(r, *v, m.path("style"));
  if (auto v = m.get("body")) l.dataset.body = text(r, *v, m.path("body"));
  if (auto v = m.get("tile_matrix_set")) l.tileMatrixSet = text(r, *v, m.path("tile_matrix_set"));
  l.dataset.mimeType = text(r, m.need("format"), m.path("format"));
  l.dataset.extension = extensionFor(l.dataset.mimeType);
  l.dataset.server = l.upstream;
  l.dataset.name = l.name;
  const bool heights =
      l.dataset.mimeType == "application/bil16" || l.dataset.mimeType == "image/tiff";
  l.kind = heights ? LayerKind::Elevation : LayerKind::Imagery;
  if (auto v = m.get("kind")) {
    constexpr LayerKind kKinds[] = {LayerKind::Imagery, LayerKind::Elevation, LayerKind::Values};
    l.kind = kKinds[choice(r, *v, m.path("kind"), {"imagery", "elevation", "values"})];
  }
  readGrid(r, m, l);

  if (l.dataset.mimeType == "image/tiff") l.elevation.encoding = ElevationEncoding::Int16Tiff;
  if (l.dataset.mimeType == "image/png") l.elevation.encoding = ElevationEncoding::Png16;
  if (m.has("elevation")) readElevation(r, m, l);
  readValues(r, m, l);
  readTime(r, m, l.time);

  readLayerCache(r, m, l);
  return l;
}

} // namespace tellus::detail::yaml
