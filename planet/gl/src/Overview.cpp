#include "Overview.hpp"

#include "Codec.hpp"
#include "LayerSet.hpp"
#include "NodeTextures.hpp"

#include <algorithm>
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
      o->keys_.push_back(TileKey{0, r, c});
  o->results_.resize(o->keys_.size());
  o->ids_.resize(o->keys_.size());
  for (std::size_t i = 0; i < o->keys_.size(); ++i)
    o->request(o->keys_[i]);
  return o;
}

Overview::Overview(
    ITileSource& source, std::string layer, std::string time, TileGrid grid, double f)
    : source_(source), layer_(std::move(layer)), time_(std::move(time)), grid_(std::move(grid)),
      factor_(f), inbox_(std::make_shared<Inbox>()) {}

Overview::~Overview() {
  if (composed_) return; // nothing in flight
  for (std::size_t i = 0; i < ids_.size(); ++i)
    if (!results_[i]) source_.cancel(ids_[i]);
}

void Overview::request(const TileKey& key) {
  const auto i =
      static_cast<std::size_t>(std::find(keys_.begin(), keys_.end(), key) - keys_.begin());
  std::weak_ptr<Inbox> weak = inbox_;
  ++requested_;
  // Above any node's score: the fallback of every node comes first.
  ids_[i] = source_.request({layer_, time_, key}, 1e16, [weak, i](TileResult&& r) {
    if (auto inbox = weak.lock()) {
      std::lock_guard lock(inbox->mutex);
      inbox->done.emplace_back(i, std::move(r));
    }
  });
}

std::optional<MipLevel> Overview::take() {
  if (composed_) return std::nullopt;
  std::vector<std::pair<std::size_t, TileResult>> done;
  {
    std::lock_guard lock(inbox_->mutex);
    done.swap(inbox_->done);
  }
  for (auto& [i, r] : done) {
    if (r.status == TileStatus::Failed) {
      request(keys_[i]); // the tile source paces its upstream; a dead one fails fast
      continue;
    }
    results_[i] = std::move(r);
  }
  if (!std::all_of(results_.begin(), results_.end(), [](const auto& r) { return r.has_value(); }))
    return std::nullopt;
  const GridSpec& g = grid_.spec();
  MipLevel image;
  image.width = static_cast<int>(grid_.colCount(0) * g.tileWidth);
  image.height = static_cast<int>(grid_.rowCount(0) * g.tileHeight);
  image.rgba.resize(static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height) *
                    4);
  for (std::size_t p = 0; p < image.rgba.size(); p += 4) { // dark blue where a tile is missing
    image.rgba[p] = 10;
    image.rgba[p + 1] = 20;
    image.rgba[p + 2] = 60;
    image.rgba[p + 3] = 255;
  }
  const auto rowBytes = static_cast<std::size_t>(g.tileWidth) * 4;
  for (std::size_t i = 0; i < keys_.size(); ++i) {
    if (results_[i]->status != TileStatus::Ok) continue;
    auto tile = decodeJpegOrPng(results_[i]->bytes);
    if (!tile || tile->width != g.tileWidth || tile->height != g.tileHeight) continue;
    // Rows from the south: tile row r (from the south) holds image rows r * h ... (r + 1) * h - 1,
    // the tile's top row (north) the highest of them.
    const auto x0 = static_cast<std::size_t>(keys_[i].col * g.tileWidth) * 4;
    for (int y = 0; y < g.tileHeight; ++y) {
      const auto dst = static_cast<std::size_t>(keys_[i].row * g.tileHeight + g.tileHeight - 1 - y);
      std::copy_n(tile->pixels.data() + static_cast<std::size_t>(y) * rowBytes,
                  rowBytes,
                  image.rgba.data() + dst * static_cast<std::size_t>(image.width) * 4 + x0);
    }
  }
  composed_ = true;
  results_.clear();
  return image;
}

void applyOverview(Overview& overview, GlTexture& global, LayerTextures& base) {
  if (auto image = overview.take()) global = makeGlobalTexture(std::move(*image));
  if (base.streamer) base.streamer->setOverviewFactor(overview.texelFactor());
  base.overviewFactor = overview.composed() ? overview.texelFactor() : 0.0;
}

} // namespace tellus::planet
