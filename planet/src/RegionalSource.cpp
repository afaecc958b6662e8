// Several datasets as one layer: see RegionalSource.hpp.

#include <tellus/cache/TileGrid.hpp>
#include <tellus/planet/RegionalSource.hpp>

#include <algorithm>
#include <utility>

namespace tellus::planet {

namespace {

// Ids handed out: odd = an inner request (id * 2 + 1); 0 = answered at once (absent), which can
// be neither cancelled nor reprioritised.
constexpr TileRequestId kAnswered = 0;

bool contains(const Sector& outer, const Sector& inner) {
  return outer.west <= inner.west && inner.east <= outer.east && outer.south <= inner.south &&
         inner.north <= outer.north;
}

} // namespace

std::expected<std::unique_ptr<RegionalTileSource>, std::string>
RegionalTileSource::create(ITileSource& inner, std::vector<CombinedLayer> layers) {
  std::vector<Combined> out;
  for (CombinedLayer& l : layers) {
    if (l.name.empty()) return std::unexpected(std::string("a combined layer needs a name"));
    if (l.datasets.empty())
      return std::unexpected("combined layer '" + l.name + "' lists no dataset");
    for (const Combined& c : out)
      if (c.name == l.name) return std::unexpected("combined layer '" + l.name + "' twice");
    // A combined layer may carry the name of one of its own datasets (the global one, say), but
    // not that of another layer, which it would hide.
    if (inner.describe(l.name) &&
        std::find(l.datasets.begin(), l.datasets.end(), l.name) == l.datasets.end())
      return std::unexpected("combined layer '" + l.name + "' would hide the layer of that name");
    Combined c;
    c.name = l.name;
    for (std::size_t i = 0; i < l.datasets.size(); ++i) {
      const std::string& d = l.datasets[i];
      const auto spec = inner.describe(d);
      if (!spec)
        return std::unexpected("combined layer '" + l.name + "': unknown layer '" + d + "'");
      const GridSpec& g = spec->grid;
      if (i == 0) {
        c.grid = g;
      } else {
        if (g.levelZeroDeltaDeg != c.grid.levelZeroDeltaDeg || g.tileWidth != c.grid.tileWidth ||
            g.tileHeight != c.grid.tileHeight)
          return std::unexpected("combined layer '" + l.name + "': '" + d +
                                 "' has another grid (level-zero size or tile size) than '" +
                                 l.datasets.front() + "'");
        c.grid.numLevels = std::max(c.grid.numLevels, g.numLevels);
        c.grid.sector.west = std::min(c.grid.sector.west, g.sector.west);
        c.grid.sector.south = std::min(c.grid.sector.south, g.sector.south);
        c.grid.sector.east = std::max(c.grid.sector.east, g.sector.east);
        c.grid.sector.north = std::max(c.grid.sector.north, g.sector.north);
      }
      const Sector& s = g.sector;
      c.datasets.push_back({d, s, g.numLevels, (s.east - s.west) * (s.north - s.south)});
    }
    // Smallest first; equal areas keep the listed order.
    auto tiles = TileGrid::create(c.grid);
    if (!tiles) return std::unexpected("combined layer '" + l.name + "': " + tiles.error());
    c.tiles = *tiles;
    std::stable_sort(c.datasets.begin(), c.datasets.end(), [](const Dataset& a, const Dataset& b) {
      return a.area < b.area;
    });
    out.push_back(std::move(c));
  }
  return std::unique_ptr<RegionalTileSource>(new RegionalTileSource(inner, std::move(out)));
}

const RegionalTileSource::Combined*
RegionalTileSource::find(std::string_view layer) const noexcept {
  for (const Combined& c : layers_)
    if (c.name == layer) return &c;
  return nullptr;
}

std::optional<DatasetSpec> RegionalTileSource::describe(std::string_view layer,
                                                        std::string_view time) const {
  const Combined* c = find(layer);
  if (c == nullptr) return inner_.describe(layer, time);
  auto spec = inner_.describe(c->datasets.back().name, time);
  if (!spec) return std::nullopt;
  spec->name = c->name;
  spec->grid = c->grid;
  return spec;
}

std::optional<std::string> RegionalTileSource::datasetFor(std::string_view layer,
                                                          const TileKey& key) const {
  const Combined* c = find(layer);
  if (c == nullptr) return std::string(layer);
  if (!c->tiles->isValid(key)) return std::nullopt;
  const Sector s = c->tiles->sectorOf(key);
  for (const Dataset& d : c->datasets)
    if (key.level < d.levels && contains(d.sector, s)) return d.name;
  return std::nullopt;
}

TileRequestId
RegionalTileSource::request(const TileAddress& address, double priority, Callback done) {
  const auto dataset = datasetFor(address.layer, address.key);
  if (!dataset) {
    TileResult r;
    r.status = TileStatus::Absent;
    r.message = "no dataset of layer '" + address.layer + "' covers this tile";
    done(std::move(r));
    return kAnswered;
  }
  TileAddress a = address;
  a.layer = *dataset;
  return inner_.request(a, priority, std::move(done)) * 2 + 1;
}

void RegionalTileSource::reprioritize(TileRequestId id, double priority) {
  if (id != kAnswered) inner_.reprioritize(id / 2, priority);
}

bool RegionalTileSource::cancel(TileRequestId id) {
  return id != kAnswered && inner_.cancel(id / 2);
}

} // namespace tellus::planet
