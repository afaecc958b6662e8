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
#include <string_view>

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

/** Whether `c` serves the same upstream data as `l` (upstream, upstream layer, style, body, kind,
 * times) on another grid. */
bool sameSource(const LayerSpec& c, const LayerSpec& l) {
  return c.name != l.name && c.upstream == l.upstream && c.upstreamLayer == l.upstreamLayer &&
         c.dataset.style == l.dataset.style && c.dataset.body == l.dataset.body &&
         c.elevation == l.elevation && !c.values && !l.values && c.timeValues == l.timeValues &&
         c.timePeriod == l.timePeriod;
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
  for (const LayerSpec& c : tiles.layers()) {
    if (!sameSource(c, l)) continue;
    const TileGrid* cg = tiles.grid(c.name);
    if (!cg) continue;
    const Sector& s = cg->spec().sector;
    if (s.west > -180.0 || s.east < 180.0 || s.south > -90.0 || s.north < 90.0) continue;
    const std::int32_t level = composeLevel(*cg, r.bbox, r.width, r.height, 0);
    const double cx = cg->deltaDeg(level) / cg->spec().tileWidth;
    const double cy = cg->deltaDeg(level) / cg->spec().tileHeight;
    if (cx > px || cy > py || cx <= bestX || cy <= bestY) continue;
    best = &c;
    bestX = cx;
    bestY = cy;
  }
  return best;
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
    Job::Layer l;
    l.spec = cl;
    l.grid = tiles_.grid(cl.layer->name);
    if (!l.grid) return std::unexpected("no layer '" + cl.layer->name + "'");
    if (const LayerSpec* coarser = coarserSource(tiles_, *cl.layer, *l.grid, r)) {
      l.spec.layer = coarser;
      l.grid = tiles_.grid(coarser->name);
    }
    l.bands = composeBands(*l.grid, r.bbox, r.width, r.height, 0);
    // The planes' chroma rows straddle two bands' rows: a map of several bands on the RGB path.
    if (l.bands.size() > 1) job->ycc = false;
    for (const ComposeBand& band : l.bands) {
      const std::size_t left = maxTiles_ > total ? maxTiles_ - total : 0;
      auto keys = job->ycc ? composeTilesYcc(*l.grid, band.box, r.width, r.height, band.level, left)
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
 * cachedTexels), and the map's own (outputTexels). */
void countSourceTexels(const MapComposer::Job& job, ComposedMap& map) {
  for (const MapComposer::Job::Layer& l : job.layers) {
    const auto texels = static_cast<std::uint64_t>(l.grid->spec().tileWidth) *
                        static_cast<std::uint64_t>(l.grid->spec().tileHeight);
    for (const TileAnswer& a : l.answers) {
      if (a.kind != TileAnswer::Kind::Tile) continue;
      (a.origin == TileOrigin::Miss ? map.upstreamTexels : map.cachedTexels) += texels;
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
