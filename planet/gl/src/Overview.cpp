#include "Overview.hpp"

#include "Codec.hpp"
#include "LayerSet.hpp"
#include "NodeTextures.hpp"

#include <tellus/planet/Quadtree.hpp>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <utility>

namespace tellus::planet {

struct Overview::Inbox {
  std::mutex mutex;
  std::vector<std::pair<std::size_t, TileResult>> done;
};

std::expected<std::unique_ptr<Overview>, std::string> Overview::start(ITileSource& source,
                                                                      const std::string& layer,
                                                                      const std::string& time,
                                                                      double baseTexelDeg) {
  const auto spec = source.describe(layer, time);
  if (!spec) return std::unexpected("unknown overview layer '" + layer + "'");
  auto grid = TileGrid::create(spec->grid);
  if (!grid) return std::unexpected("overview layer '" + layer + "': " + grid.error());
  const Sector& s = grid->spec().sector;
  if (s.west > -180.0 || s.east < 180.0 || s.south > -90.0 || s.north < 90.0)
    return std::unexpected("overview layer '" + layer + "' does not cover the whole globe");
  if (grid->rowCount(0) * grid->colCount(0) > 64)
    return std::unexpected("overview layer '" + layer + "' has more than 64 level-zero tiles");
  const double texel = grid->spec().levelZeroDeltaDeg / grid->spec().tileWidth;
  std::unique_ptr<Overview> o(new Overview(source, layer, time, *grid, texel / baseTexelDeg));
  for (std::int64_t r = 0; r < grid->rowCount(0); ++r)
    for (std::int64_t c = 0; c < grid->colCount(0); ++c)
      o->tiles_.push_back({TileKey{0, r, c}, false, 0, std::nullopt, {}});
  return o;
}

Overview::Overview(
    ITileSource& source, std::string layer, std::string time, TileGrid grid, double f)
    : source_(source), layer_(std::move(layer)), time_(std::move(time)), grid_(std::move(grid)),
      factor_(f), inbox_(std::make_shared<Inbox>()) {}

Overview::~Overview() {
  for (const Tile& t : tiles_)
    if (t.asked && !t.result) source_.cancel(t.id);
}

void Overview::request(std::size_t i) {
  std::weak_ptr<Inbox> weak = inbox_;
  tiles_[i].asked = true;
  // Above any node's score: the fallback of every drawn node comes first.
  tiles_[i].id = source_.request({layer_, time_, tiles_[i].key}, 1e16, [weak, i](TileResult&& r) {
    if (auto inbox = weak.lock()) {
      std::lock_guard lock(inbox->mutex);
      inbox->done.emplace_back(i, std::move(r));
    }
  });
}

template <typename F> void Overview::forTilesUnder(const Node& n, F&& f) const {
  const Sector s = n.sector();
  const double d = grid_.spec().levelZeroDeltaDeg;
  const auto cols = grid_.colCount(0), rows = grid_.rowCount(0);
  const auto clampTo = [](double v, std::int64_t hi) {
    return std::clamp(static_cast<std::int64_t>(v), std::int64_t{0}, hi - 1);
  };
  const std::int64_t c0 = clampTo(std::floor((s.west + 180.0) / d), cols);
  const std::int64_t c1 = clampTo(std::ceil((s.east + 180.0) / d) - 1.0, cols);
  const std::int64_t r0 = clampTo(std::floor((s.south + 90.0) / d), rows);
  const std::int64_t r1 = clampTo(std::ceil((s.north + 90.0) / d) - 1.0, rows);
  for (std::int64_t r = r0; r <= r1; ++r)
    for (std::int64_t c = c0; c <= c1; ++c)
      f(static_cast<std::size_t>(r * cols + c));
}

void Overview::want(const std::vector<Node*>& drawn) {
  for (const Node* n : drawn)
    forTilesUnder(*n, [this](std::size_t i) {
      if (!tiles_[i].asked) request(i);
    });
}

bool Overview::covers(const std::vector<Node*>& drawn) const {
  bool all = true;
  for (const Node* n : drawn)
    if (n->level() == 0)
      forTilesUnder(*n, [&](std::size_t i) { all = all && tiles_[i].result.has_value(); });
  return all;
}

std::optional<MipLevel> Overview::take() {
  std::vector<std::pair<std::size_t, TileResult>> done;
  {
    std::lock_guard lock(inbox_->mutex);
    done.swap(inbox_->done);
  }
  if (done.empty()) return std::nullopt;
  const GridSpec& g = grid_.spec();
  for (auto& [i, r] : done) {
    if (r.status == TileStatus::Failed) {
      request(i); // the tile source paces its upstream; a dead one fails fast
      continue;
    }
    if (r.status == TileStatus::Ok)
      if (auto image = decodeJpegOrPng(r.bytes);
          image && image->width == g.tileWidth && image->height == g.tileHeight)
        tiles_[i].rgba = std::move(image->pixels);
    r.bytes.clear();
    tiles_[i].result = std::move(r);
  }
  MipLevel image;
  image.width = static_cast<int>(grid_.colCount(0) * g.tileWidth);
  image.height = static_cast<int>(grid_.rowCount(0) * g.tileHeight);
  image.rgba.resize(static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height) *
                    4);
  for (std::size_t p = 0; p < image.rgba.size(); p += 4) { // dark blue where no tile is
    image.rgba[p] = 10;
    image.rgba[p + 1] = 20;
    image.rgba[p + 2] = 60;
    image.rgba[p + 3] = 255;
  }
  const auto rowBytes = static_cast<std::size_t>(g.tileWidth) * 4;
  for (const Tile& t : tiles_) {
    if (t.rgba.empty()) continue;
    // Rows from the south: tile row r (from the south) holds image rows r * h ... (r + 1) * h - 1,
    // its top row (north) the highest of them.
    const auto x0 = static_cast<std::size_t>(t.key.col * g.tileWidth) * 4;
    for (int y = 0; y < g.tileHeight; ++y) {
      const auto dst = static_cast<std::size_t>(t.key.row * g.tileHeight + g.tileHeight - 1 - y);
      std::copy_n(t.rgba.data() + static_cast<std::size_t>(y) * rowBytes,
                  rowBytes,
                  image.rgba.data() + dst * static_cast<std::size_t>(image.width) * 4 + x0);
    }
  }
  return image;
}

void applyOverview(Overview& overview, GlTexture& global, LayerTextures& base) {
  if (auto image = overview.take()) global = makeGlobalTexture(std::move(*image));
  if (base.streamer) base.streamer->setOverviewFactor(overview.texelFactor());
}

void overviewUnder(Overview& overview, LayerTextures& base) {
  const std::vector<Node*>& drawn = base.tree->drawList();
  overview.want(drawn);
  base.overviewFactor = overview.covers(drawn) ? overview.texelFactor() : 0.0;
}

} // namespace tellus::planet
