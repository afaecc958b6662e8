// `tellus height --lat A --lon B`: the terrain height there from the deepest level of the
// elevation layer that has a tile at the point (with the neighbours its bilinear taps reach), the
// same height function the renderer draws (planet::HeightField). With `--values LAYER` (issue 24):
// the value of a layer of values there, with its unit, by the function GetFeatureInfo answers
// with (values::decode, then values::sample in the tile).

#include "Commands.hpp"
#include "Context.hpp"
#include "GlobeArgs.hpp"
#include "PlanetTiles.hpp"

#include <tellus/cache/TileGrid.hpp>
#include <tellus/cli/Values.hpp>
#include <tellus/config/Config.hpp>
#include <tellus/planet/Terrain.hpp>
#include <tellus/values/ValueFormat.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <future>
#include <memory>
#include <string>
#include <vector>

namespace tellus::commands {
namespace {

int usage(const char* what, const std::string& got) {
  std::fprintf(stderr, "tellus height: %s, got '%s'\n", what, got.c_str());
  return kExitUsage;
}

/** One tile, waited for (the tile source answers on its own threads). */
TileResult fetchTile(ITileSource& source, const TileAddress& address, std::chrono::seconds limit) {
  auto done = std::make_shared<std::promise<TileResult>>();
  auto answer = done->get_future();
  source.request(address, 1.0, [done](TileResult&& r) { done->set_value(std::move(r)); });
  if (answer.wait_for(limit) != std::future_status::ready) {
    TileResult late;
    late.status = TileStatus::Failed;
    late.message = "no answer within " + std::to_string(limit.count()) + " s";
    return late;
  }
  return answer.get();
}

/** The heights at a point read two ways from the same tiles: as the layer gives them (H, above
 * mean sea level) and as the renderer draws them (h = H + N when renderer.geoid is on,
 * applyVerticalDatum per tile). */
struct PointHeights {
  planet::HeightField field;
  planet::HeightField drawn;
  std::string lastError; ///< of the last tile that failed
};

/** The tile at the point on `level` and the neighbours within one sample of it (bilinear taps)
 * into `heights`; whether the tile at the point itself was there. */
bool loadLevel(const TileGrid& grid,
               int level,
               double la,
               double lo,
               ITileSource& source,
               const planet::RendererOptions& ro,
               PointHeights& heights) {
  const auto centre = grid.keyAt(la, lo == 180.0 ? -180.0 : lo, level);
  if (!centre) return false;
  const Sector s = grid.sectorOf(*centre);
  const double dx = (s.east - s.west) / grid.spec().tileWidth;
  const double dy = (s.north - s.south) / grid.spec().tileHeight;
  std::vector<TileKey> keys{*centre};
  for (const double y : {la - dy, la, la + dy})
    for (const double x : {lo - dx, lo, lo + dx}) {
      const auto k = grid.keyAt(std::clamp(y, -90.0, 90.0), std::remainder(x, 360.0), level);
      if (k && std::find(keys.begin(), keys.end(), *k) == keys.end()) keys.push_back(*k);
    }
  bool haveCentre = false;
  for (const TileKey& k : keys) {
    const TileResult r = fetchTile(source, {ro.elevationLayer, "", k}, std::chrono::seconds(60));
    if (r.status != TileStatus::Ok) {
      if (r.status == TileStatus::Failed) heights.lastError = r.message;
      continue;
    }
    const int tw = grid.spec().tileWidth, th = grid.spec().tileHeight;
    auto t =
        ro.heightDecoder
            ? ro.heightDecoder(k, tw, th, r.bytes, r.contentType, ro.elevationEncoding)
            : planet::decodeHeightTile(k, tw, th, r.bytes, r.contentType, ro.elevationEncoding);
    if (!t) {
      heights.lastError = t.error();
      continue;
    }
    planet::HeightTile onEllipsoid = *t;
    planet::applyVerticalDatum(onEllipsoid, grid.sectorOf(k), ro.verticalDatum);
    heights.field.insert(std::move(*t));
    heights.drawn.insert(std::move(onEllipsoid));
    haveCentre = haveCentre || k == *centre;
  }
  return haveCentre;
}

void printHeights(const planet::RendererOptions& ro,
                  const std::string& body,
                  int level,
                  double H,
                  double h,
                  bool ellipsoid) {
  std::printf("%.2f\n", ellipsoid ? h : H);
  if (body != "earth")
    // No geoid but the Earth's: another body's heights are above its own reference surface
    // (the Moon's sphere, Mars's ellipsoid: the datum its data are given against).
    std::fprintf(stderr,
                 "tellus height: layer %s, level %d: H %.2f m above the reference surface of "
                 "%s, drawn as a height above it; printed: H\n",
                 ro.elevationLayer.c_str(),
                 level,
                 H,
                 body.c_str());
  else if (ro.verticalDatum.usesGeoid())
    std::fprintf(stderr,
                 "tellus height: layer %s, level %d: H %.2f m above mean sea level, h = H + N "
                 "%.2f m above the WGS84 ellipsoid (N %.2f m, EGM96; the renderer draws h); "
                 "printed: %s\n",
                 ro.elevationLayer.c_str(),
                 level,
                 H,
                 h,
                 h - H,
                 ellipsoid ? "h" : "H");
  else
    std::fprintf(stderr,
                 "tellus height: layer %s, level %d: H %.2f m above mean sea level, drawn as a "
                 "height above the ellipsoid (the geoid off); printed: H\n",
                 ro.elevationLayer.c_str(),
                 level,
                 H);
}

/** `--values LAYER`: the layer's value at the point from the deepest level with a tile there:
 * values::sample of the decoded tile at the point's place in it (bilinear between texel centres,
 * the nearest texel with data beside no data), what GetFeatureInfo answers for a map drawn from
 * that level (proxy/src/frontend/WmsValues.cpp). Prints the value (or "no data"); the layer,
 * level and unit on stderr. */
int printValue(const cli::Args& a, double la, double lo, const std::string& name) {
  planet::RendererOptions ro;
  auto tiles = openPlanetTiles(a, "height", ro);
  if (!tiles) return tiles.error();
  const LayerConfig* lc = tiles->ctx ? tiles->ctx->config.layer(name) : nullptr;
  if (lc == nullptr || lc->kind != LayerKind::Values)
    return usage("--values must name a layer of values (kind: values) of the local configuration",
                 name);
  const auto grid = TileGrid::create(lc->dataset.grid);
  if (!grid) {
    std::fprintf(stderr, "tellus height: %s\n", grid.error().c_str());
    return kExitError;
  }
  std::string lastError;
  for (int level = grid->numLevels() - 1; level >= 0; --level) {
    const auto key = grid->keyAt(la, lo == 180.0 ? -180.0 : lo, level);
    if (!key) continue;
    const TileResult r = fetchTile(*tiles->source, {name, "", *key}, std::chrono::seconds(60));
    if (r.status != TileStatus::Ok) {
      if (r.status == TileStatus::Failed) lastError = r.message;
      continue;
    }
    auto raster =
        values::decode(r.bytes, lc->values.format, grid->spec().tileWidth, grid->spec().tileHeight);
    if (!raster) {
      lastError = raster.error();
      continue;
    }
    const Sector s = grid->sectorOf(*key);
    const float v = values::sample(*raster,
                                   (lo - s.west) / (s.east - s.west) * raster->width,
                                   (s.north - la) / (s.north - s.south) * raster->height);
    if (std::isnan(v))
      std::printf("no data\n");
    else
      std::printf("%.6g\n", static_cast<double>(v));
    std::fprintf(stderr,
                 "tellus height: layer %s, level %d: %s%s%s\n",
                 name.c_str(),
                 level,
                 std::isnan(v) ? "no data" : std::to_string(v).c_str(),
                 lc->values.format.unit.empty() || std::isnan(v) ? "" : " ",
                 std::isnan(v) ? "" : lc->values.format.unit.c_str());
    return kExitOk;
  }
  std::fprintf(stderr,
               "tellus height: no tile of %s at %.6f, %.6f%s%s\n",
               name.c_str(),
               la,
               lo,
               lastError.empty() ? "" : ": ",
               lastError.c_str());
  return kExitError;
}

int runHeight(const cli::Args& a) {
  const auto latArg = a.get("lat"), lonArg = a.get("lon");
  if (!latArg || !lonArg) return usage("--lat and --lon are required", "");
  const auto lat = cli::parseNumbers(*latArg, 1, 1), lon = cli::parseNumbers(*lonArg, 1, 1);
  if (!lat || !((*lat)[0] >= -90.0 && (*lat)[0] <= 90.0))
    return usage("--lat must be a latitude in [-90, 90]", *latArg);
  if (!lon || !std::isfinite((*lon)[0])) return usage("--lon must be a longitude", *lonArg);
  if (const auto layer = a.get("values")) {
    if (a.get("elevation") || a.get("datum"))
      return usage("--values takes neither --elevation nor --datum", *layer);
    return printValue(a, (*lat)[0], std::remainder((*lon)[0], 360.0), *layer);
  }
  const auto datumArg = a.get("datum");
  if (datumArg && *datumArg != "msl" && *datumArg != "ellipsoid")
    return usage("--datum must be msl or ellipsoid", *datumArg);
  planet::RendererOptions ro;
  auto tiles = openPlanetTiles(a, "height", ro);
  if (!tiles) return tiles.error();
  if (const auto layer = a.get("elevation")) ro.elevationLayer = *layer;
  if (ro.elevationLayer.empty()) {
    std::fprintf(stderr, "tellus height: no elevation layer (renderer.terrain)\n");
    return kExitError;
  }
  const auto spec = tiles->source->describe(ro.elevationLayer, "");
  if (!spec) return usage("--elevation must name an elevation layer", ro.elevationLayer);
  const auto grid = TileGrid::create(spec->grid);
  if (!grid) {
    std::fprintf(stderr, "tellus height: %s\n", grid.error().c_str());
    return kExitError;
  }
  PointHeights heights{planet::HeightField(*grid), planet::HeightField(*grid), {}};
  // A pole is one point: its longitude is 0, as HeightField takes it (the tiles loaded around the
  // point must be those it reads).
  const double la = (*lat)[0];
  const double lo = std::abs(la) == 90.0 ? 0.0 : std::remainder((*lon)[0], 360.0);
  int level = grid->numLevels() - 1;
  while (level >= 0 && !loadLevel(*grid, level, la, lo, *tiles->source, ro, heights))
    --level;
  if (level < 0) {
    std::fprintf(stderr,
                 "tellus height: no elevation tile at %.6f, %.6f%s%s\n",
                 la,
                 lo,
                 heights.lastError.empty() ? "" : ": ",
                 heights.lastError.c_str());
    return kExitError;
  }
  const double H = heights.field.heightAt(la, lo), h = heights.drawn.heightAt(la, lo);
  const bool ellipsoid = datumArg && *datumArg == "ellipsoid";
  if (ellipsoid && !ro.verticalDatum.usesGeoid()) {
    std::fprintf(stderr, "tellus height: --datum ellipsoid needs the geoid (--geoid on)\n");
    return kExitUsage;
  }
  printHeights(ro, tiles->body, level, H, h, ellipsoid);
  return kExitOk;
}

} // namespace

Command heightCommand() {
  using K = cli::OptionKind;
  Command c{"height", tileSourceOptions(), 0, &runHeight};
  c.options.insert(c.options.end(),
                   {{"lat", K::Value},
                    {"lon", K::Value},
                    {"elevation", K::Value},
                    {"datum", K::Value},
                    {"values", K::Value}});
  return c;
}

} // namespace tellus::commands
