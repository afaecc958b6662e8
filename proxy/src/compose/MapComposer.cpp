// GetMap for any box, up to the moment its tiles have all answered: the layers' tiles chosen
// (composeTiles, composeTilesYcc) and asked of the tile service in parallel; the last answer
// posts the job to the composer's workers, where renderMap (MapRender.cpp) makes the map.
#include "compose/MapComposer.hpp"

#include "compose/MapJob.hpp"
#include "tiles/WorkerPool.hpp"

#include <tellus/proxy/Compose.hpp>

#include <algorithm>
#include <cstdlib>
#include <mutex>
#include <optional>
#include <set>
#include <string_view>
#include <tuple>
#include <utility>
#include <vector>

namespace tellus {

struct MapComposer::Pool {
  WorkerPool workers;
  explicit Pool(int n) : workers(n) {}
};

MapComposer::MapComposer(TileService& tiles,
                         int threads,
                         std::size_t maxTiles,
                         std::size_t decodedCacheBytes,
                         int jpegQuality)
    : tiles_(tiles), maxTiles_(maxTiles), jpegQuality_(jpegQuality),
      decodedCache_(decodedCacheBytes > 0 ? std::make_unique<DecodedTileCache>(decodedCacheBytes)
                                          : nullptr),
      gate_(std::make_shared<Gate>()), pool_(std::make_unique<Pool>(threads)) {
  gate_->pool = &pool_->workers;
  if (const char* e = std::getenv("TELLUS_COMPOSE_YCC"); e && std::string_view(e) == "0")
    yccDisabled_ = true;
}

namespace {

/** `more` added to `keys`: a tile two bands both sample once, with the union of their regions
 * (bands of one level are apart only when a map straddles the equator). */
void appendTiles(std::vector<ComposeTile>& keys, std::vector<ComposeTile>&& more) {
  if (keys.empty()) {
    keys = std::move(more);
    return;
  }
  for (ComposeTile& c : more) {
    auto it = std::find_if(keys.begin(), keys.end(), [&](const ComposeTile& k) {
      return k.key.level == c.key.level && k.key.row == c.key.row && k.key.col == c.key.col;
    });
    if (it == keys.end()) {
      keys.push_back(c);
    } else {
      it->region = {std::min(it->region[0], c.region[0]),
                    std::min(it->region[1], c.region[1]),
                    std::max(it->region[2], c.region[2]),
                    std::max(it->region[3], c.region[3])};
    }
  }
}

/** The layers a map of `l` may take its coarse rows from: the same upstream data
 * (sameUpstreamData) on a global grid. */
std::vector<std::pair<const LayerSpec*, const TileGrid*>>
coarserCandidates(const TileService& tiles, const LayerSpec& l) {
  std::vector<std::pair<const LayerSpec*, const TileGrid*>> out;
  for (const LayerSpec& c : tiles.layers()) {
    if (!sameUpstreamData(c, l)) continue;
    const TileGrid* cg = tiles.grid(c.name);
    if (!cg) continue;
    const Sector& s = cg->spec().sector;
    if (s.west > -180.0 || s.east < 180.0 || s.south > -90.0 || s.north < 90.0) continue;
    out.emplace_back(&c, cg);
  }
  return out;
}

/**
 * The layer a map of latitude rows coarser than `l`'s level zero is composed from (issue 29):
 * another layer of the same upstream data on a global grid (e.g. the one `renderer.overview`
 * names), the coarsest whose level for this map still has texels at most kMaxUpsampling times
 * its pixels and coarser than `l`'s on both axes; null when there is none (the map then takes
 * `l`'s level zero, however many of its tiles that needs).
 */
const LayerSpec* coarserSource(const TileService& tiles,
                               const LayerSpec& l,
                               const TileGrid& g,
                               const ComposeRequest& r) {
  if (r.bbox.rows != MapRows::Latitude || r.width <= 0 || r.height <= 0) return nullptr;
  if (composeLevel(g, r.bbox, r.width, r.height, 0) != 0) return nullptr;
  const double px = (r.bbox.east - r.bbox.west) / r.width * kMaxUpsampling * (1.0 + 1e-9);
  const double py = (r.bbox.north - r.bbox.south) / r.height * kMaxUpsampling * (1.0 + 1e-9);
  double bestX = g.deltaDeg(0) / g.spec().tileWidth;
  double bestY = g.deltaDeg(0) / g.spec().tileHeight;
  const LayerSpec* best = nullptr;
  for (const auto& [c, cg] : coarserCandidates(tiles, l)) {
    const std::int32_t level = composeLevel(*cg, r.bbox, r.width, r.height, 0);
    const double cx = cg->deltaDeg(level) / cg->spec().tileWidth;
    const double cy = cg->deltaDeg(level) / cg->spec().tileHeight;
    if (cx > px || cy > py || cx <= bestX || cy <= bestY) continue;
    best = c;
    bestX = cx;
    bestY = cy;
  }
  return best;
}

/** A Web Mercator map's rows split between `l` and a coarser layer (mercatorSplit). */
struct MercatorSplit {
  const LayerSpec* coarser = nullptr;
  std::vector<ComposeBand> coarserBands; ///< the rows composed from `coarser`
  std::vector<ComposeBand> rest;         ///< the other rows, from `l` at its bands' levels
};

/**
 * coarserSource for a Web Mercator map (issue 29): its rows' pixels shrink in latitude towards the
 * poles (composeBands), so a world map's equatorial rows are far coarser than `l`'s level zero and
 * its polar rows are not. Each row that takes `l`'s level zero and that a level of another layer
 * of the same upstream data on a coarser global grid is fine enough for (kMaxUpsampling), with
 * texels coarser than `l`'s level zero on both axes, is composed from that layer (of several, the
 * one whose texels over those rows are largest); the other rows stay with `l`. Nothing when no
 * row gains.
 */
std::optional<MercatorSplit> mercatorSplit(const TileService& tiles,
                                           const LayerSpec& l,
                                           const TileGrid& g,
                                           const ComposeRequest& r,
                                           const std::vector<ComposeBand>& bands) {
  if (r.bbox.rows != MapRows::Mercator || r.width <= 0 || r.height <= 0) return std::nullopt;
  const std::int32_t h = r.height;
  std::vector<std::int32_t> levelOf(static_cast<std::size_t>(h), 0); // `l`'s level of each row
  for (const ComposeBand& b : bands)
    for (std::int32_t j = std::max(b.box.rowBegin, 0); j < std::min(b.box.rowEnd, h); ++j)
      levelOf[static_cast<std::size_t>(j)] = b.level;
  if (std::find(levelOf.begin(), levelOf.end(), 0) == levelOf.end()) return std::nullopt;
  std::vector<double> pixelY(static_cast<std::size_t>(h));
  for (std::int32_t j = 0; j < h; ++j)
    pixelY[static_cast<std::size_t>(j)] =
        r.bbox.rowEdgeLatitude(j, h) - r.bbox.rowEdgeLatitude(j + 1, h);
  const double pixelX = (r.bbox.east - r.bbox.west) / r.width;
  const double lx = g.deltaDeg(0) / g.spec().tileWidth, ly = g.deltaDeg(0) / g.spec().tileHeight;
  const LayerSpec* best = nullptr;
  std::vector<std::int32_t> bestLevels; // per row: the coarser layer's level, -1: `l`
  double bestScore = 0.0;
  for (const auto& [c, cg] : coarserCandidates(tiles, l)) {
    std::vector<std::int32_t> levels(static_cast<std::size_t>(h), -1);
    double score = 0.0; // the texels' area over the rows it takes: larger, fewer tiles
    for (std::size_t j = 0; j < levels.size(); ++j) {
      if (levelOf[j] != 0 || !(pixelY[j] > 0.0)) continue;
      const auto fine = fineEnoughLevel(*cg, pixelX, pixelY[j]);
      if (!fine) continue;
      const std::int32_t level = *fine;
      const double cx = cg->deltaDeg(level) / cg->spec().tileWidth;
      const double cy = cg->deltaDeg(level) / cg->spec().tileHeight;
      if (cx <= lx || cy <= ly) continue;
      levels[j] = level;
      score += cx * cy;
    }
    if (score > bestScore) {
      best = c;
      bestLevels = std::move(levels);
      bestScore = score;
    }
  }
  if (!best) return std::nullopt;
  MercatorSplit split;
  split.coarser = best;
  // Runs of rows of one source and level are bands; a row past the square (it draws nothing)
  // stays with `l`'s band around it.
  for (std::int32_t j = 0; j < h; ++j) {
    const std::int32_t c = bestLevels[static_cast<std::size_t>(j)];
    std::vector<ComposeBand>& into = c >= 0 ? split.coarserBands : split.rest;
    const std::int32_t level = c >= 0 ? c : levelOf[static_cast<std::size_t>(j)];
    if (!into.empty() && into.back().box.rowEnd == j && into.back().level == level) {
      into.back().box.rowEnd = j + 1;
      continue;
    }
    MapBox box = r.bbox;
    box.rowBegin = j;
    box.rowEnd = j + 1;
    into.push_back(ComposeBand{box, level});
  }
  return split;
}

/** The texels of the tiles `grid`'s `bands` of the map need (each tile once). */
std::uint64_t tileTexels(const TileGrid& grid,
                         const std::vector<ComposeBand>& bands,
                         const ComposeRequest& r,
                         std::size_t maxTiles) {
  std::set<std::tuple<std::int32_t, std::int32_t, std::int32_t>> keys;
  for (const ComposeBand& b : bands)
    if (auto tiles = composeTiles(grid, b.box, r.width, r.height, b.level, maxTiles))
      for (const ComposeTile& t : *tiles)
        keys.emplace(t.key.level, t.key.row, t.key.col);
  return keys.size() * static_cast<std::uint64_t>(grid.spec().tileWidth) *
         static_cast<std::uint64_t>(grid.spec().tileHeight);
}

} // namespace

std::size_t MapComposer::decodedCacheBytes() const {
  return decodedCache_ ? decodedCache_->bytes() : 0;
}

MapComposer::~MapComposer() {
  // Tile answers may still arrive (from the tile service's threads) after this: they find no
  // pool and drop their job. Jobs already queued run now, while everything they use lives.
  {
    std::lock_guard lock(gate_->mutex);
    gate_->pool = nullptr;
  }
  pool_.reset();
}

std::expected<void, std::string>
MapComposer::compose(ComposeRequest request,
                     std::function<void(const LayerSpec&, const TileAnswer&)> onTile,
                     std::function<void(ComposedMap&&)> done) {
  auto job = std::make_shared<Job>();
  job->request = std::move(request);
  job->onTile = std::move(onTile);
  job->done = std::move(done);
  const ComposeRequest& r = job->request;
  job->ycc = r.format == MapFormat::Jpeg && r.layers.size() == 1 &&
             !r.layers.front().layer->elevation && r.layers.front().colourMap == nullptr &&
             r.layers.front().opacity >= 1.0 - 1.0 / 512 && !yccDisabled_;
  std::size_t total = 0;
  for (const ComposeLayer& cl : r.layers) {
    Job::Layer whole;
    whole.spec = cl;
    whole.grid = tiles_.grid(cl.layer->name);
    if (!whole.grid) return std::unexpected("no layer '" + cl.layer->name + "'");
    if (const LayerSpec* coarser = coarserSource(tiles_, *cl.layer, *whole.grid, r)) {
      whole.spec.layer = coarser;
      whole.grid = tiles_.grid(coarser->name);
    }
    whole.bands = composeBands(*whole.grid, r.bbox, r.width, r.height, 0);
    // A Web Mercator map: the rows coarser than level zero from a coarser layer, drawn as a layer
    // of their own before the other rows (none of them overlaps).
    std::vector<Job::Layer> parts;
    if (auto split = mercatorSplit(tiles_, *cl.layer, *whole.grid, r, whole.bands);
        split && tileTexels(*tiles_.grid(split->coarser->name), split->coarserBands, r, maxTiles_) +
                         tileTexels(*whole.grid, split->rest, r, maxTiles_) <
                     tileTexels(*whole.grid, whole.bands, r, maxTiles_)) { // and it costs less
      Job::Layer coarse = whole;
      coarse.spec.layer = split->coarser;
      coarse.grid = tiles_.grid(split->coarser->name);
      coarse.bands = std::move(split->coarserBands);
      parts.push_back(std::move(coarse));
      whole.bands = std::move(split->rest);
    }
    if (!whole.bands.empty()) parts.push_back(std::move(whole));
    for (Job::Layer& l : parts) {
      // The planes' chroma rows straddle two bands' rows: a map of several bands on the RGB path.
      if (l.bands.size() > 1 || parts.size() > 1) job->ycc = false;
      for (const ComposeBand& band : l.bands) {
        const std::size_t left = maxTiles_ > total ? maxTiles_ - total : 0;
        auto keys = job->ycc
                        ? composeTilesYcc(*l.grid, band.box, r.width, r.height, band.level, left)
                        : composeTiles(*l.grid, band.box, r.width, r.height, band.level, left);
        if (!keys) {
          return std::unexpected("the map needs more than " + std::to_string(maxTiles_) +
                                 " tiles (level " + std::to_string(band.level) + " of layer '" +
                                 cl.layer->name + "'); ask for a smaller box or fewer pixels");
        }
        total += keys->size();
        appendTiles(l.keys, std::move(*keys));
      }
      l.answers.resize(l.keys.size());
      job->layers.push_back(std::move(l));
    }
  }
  total = 0;
  for (const Job::Layer& l : job->layers)
    total += l.keys.size();
  job->pending = total + 1; // +1: the loop below, so nothing finishes before every fetch starts
  const auto arrived = [this, gate = gate_, job] {
    if (job->pending.fetch_sub(1) != 1) return;
    std::lock_guard lock(gate->mutex);
    if (gate->pool) gate->pool->post([this, job] { finish(job); });
  };
  for (std::size_t li = 0; li < job->layers.size(); ++li) {
    Job::Layer& l = job->layers[li];
    for (std::size_t k = 0; k < l.keys.size(); ++k) {
      tiles_.getTile(
          l.spec.layer->name,
          l.spec.time,
          l.keys[k].key,
          [job, li, k, arrived](TileAnswer&& a) {
            job->layers[li].answers[k] = std::move(a);
            arrived();
          },
          FetchGate{r.fetchBudget, r.client});
    }
  }
  arrived();
  return {};
}

namespace {

/** The texels of the tiles a map was asked to be made of, into `map` (upstreamTexels,
 * cachedTexels, joinedTexels), and the map's own (outputTexels). */
void countSourceTexels(const MapComposer::Job& job, ComposedMap& map) {
  for (const MapComposer::Job::Layer& l : job.layers) {
    const auto texels = static_cast<std::uint64_t>(l.grid->spec().tileWidth) *
                        static_cast<std::uint64_t>(l.grid->spec().tileHeight);
    for (const TileAnswer& a : l.answers) {
      if (a.kind != TileAnswer::Kind::Tile) continue;
      (a.origin != TileOrigin::Miss ? map.cachedTexels
       : a.joinedInFlight           ? map.joinedTexels
                                    : map.upstreamTexels) += texels;
    }
  }
  if (map.kind == ComposedMap::Kind::Map) {
    map.outputTexels = static_cast<std::uint64_t>(job.request.width) *
                       static_cast<std::uint64_t>(job.request.height);
  }
}

} // namespace

void MapComposer::finish(const std::shared_ptr<Job>& job) {
  try {
    ComposedMap map = renderMap(*job, tiles_, decodedCache_.get(), jpegQuality_);
    countSourceTexels(*job, map);
    job->done(std::move(map));
  } catch (const std::exception& e) {
    ComposedMap failedMap;
    failedMap.kind = ComposedMap::Kind::Error;
    failedMap.message = std::string("cannot compose the map: ") + e.what();
    job->done(std::move(failedMap));
  }
}

} // namespace tellus
