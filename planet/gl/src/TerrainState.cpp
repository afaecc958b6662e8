#include "TerrainState.hpp"

#include "HeightDecode.hpp"
#include "LayerSet.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <unordered_set>
#include <utility>

namespace tellus::planet {

bool reliefCouldShow(const Camera& camera, double altitudeM, double boundM, double minPx) {
  const double f = camera.isFisheye()
                       ? camera.pixelsPerRadian()
                       : 0.5 * camera.viewport().height /
                             std::tan(camera.verticalFovDeg() * std::numbers::pi / 360.0);
  const double distance = altitudeM - boundM;
  return !(distance > 0.0 && boundM * f / distance < minPx);
}

std::expected<void, std::string> TerrainState::open(ITileSource& source) {
  if (!(opt_.verticalExaggeration > 0.0) || !std::isfinite(opt_.verticalExaggeration))
    return std::unexpected(std::string("the vertical exaggeration must be a positive number"));
  const auto espec = source.describe(opt_.elevationLayer, opt_.elevationTime);
  if (!espec) return std::unexpected("unknown elevation layer '" + opt_.elevationLayer + "'");
  auto egrid = TileGrid::create(espec->grid);
  if (!egrid) return std::unexpected("layer '" + opt_.elevationLayer + "': " + egrid.error());
  field_ = std::make_unique<HeightField>(*egrid);
  field_->setFade(opt_.fadeInSeconds); // heights that arrive fade in as textures do (issue 23)
  HeightStreamParams hp;
  hp.layer = opt_.elevationLayer;
  hp.time = opt_.elevationTime;
  hp.encoding = opt_.elevationEncoding;
  hp.datum = opt_.verticalDatum;
  heights_ = std::make_unique<HeightStreamer>(
      source, *egrid, hp, opt_.heightDecoder ? opt_.heightDecoder : HeightDecoder(decodeHeights));
  return {};
}

void TerrainState::applyTo(Quadtree& tree, double chordDepthM) const {
  if (!field_) {
    tree.setTerrain({}, -chordDepthM);
    return;
  }
  const TerrainState* self = this;
  tree.setTerrain(
      [self](const Sector& sec) {
        if (self->reliefOff_) return std::pair{0.0, 0.0};
        const auto [lo, hi] = self->field_->rangeOver(sec);
        const double x = self->opt_.verticalExaggeration;
        return std::pair{lo * x, hi * x};
      },
      (reliefOff_ ? 0.0 : std::min(0.0, field_->lowest() * opt_.verticalExaggeration)) -
          chordDepthM);
}

void TerrainState::chooseRelief(const Camera& camera, double altitudeM, LayerSet& layers) {
  bool off = false;
  if (field_ && opt_.terrainMinReliefPx > 0.0 && std::isfinite(altitudeM)) {
    const double bound =
        std::max(opt_.terrainReliefBoundM, -field_->lowest()) * opt_.verticalExaggeration;
    off = !reliefCouldShow(camera, altitudeM, bound, opt_.terrainMinReliefPx);
  }
  if (off == reliefOff_) return;
  reliefOff_ = off;
  layers.forEach([&](LayerTextures& t) {
    applyTo(*t.tree, t.chordDepthM);
    t.tree->refreshHeights([](const Sector&) { return true; });
  });
}

void TerrainState::deliver(LayerSet& layers) {
  if (!field_) return;
  const std::uint64_t before = field_->generation();
  if (heights_->deliver(*field_, 8) == 0) return;
  layers.forEach([&](LayerTextures& t) {
    t.tree->refreshHeights([&](const Sector& sec) { return field_->changedSince(before, sec); });
    applyTo(*t.tree, t.chordDepthM);
  });
}

void TerrainState::want(const Quadtree& geo, double nowS, RenderStats& stats) {
  if (!field_) return;
  wish_.clear();
  stats.nodesWithoutHeights = reliefOff_ ? geo.drawList().size() : 0;
  for (const Node* node : geo.drawList()) {
    if (reliefOff_) break;
    const Sector& s = node->sector();
    const int level = heightLevelFor(*node);
    for (int l = 0; l <= level; l = l == level ? level + 1 : std::min(level, l + 3)) {
      const auto keys = field_->grid().keysCovering(s, l, node->isCap() ? kCapHeightKeys : 16);
      if (keys) wish_.insert(wish_.end(), keys->begin(), keys->end());
    }
  }
  std::stable_sort(wish_.begin(), wish_.end(), [](const TileKey& a, const TileKey& b) {
    return a.level < b.level;
  });
  wish_.erase(std::unique(wish_.begin(), wish_.end()), wish_.end());
  {
    std::unordered_set<TileKey, TileKeyHash> seen;
    std::erase_if(wish_, [&](const TileKey& k) { return !seen.insert(k).second; });
  }
  heights_->want(wish_, *field_, nowS);
  const HeightStreamStats& hs = heights_->stats();
  stats.heightTilesRequested = hs.requested;
  stats.heightTilesReceived = hs.received;
  stats.heightTilesAbsent = hs.absent;
  stats.heightTilesFailed = hs.failed + hs.decodeErrors;
}

int TerrainState::heightLevelFor(const Node& node) const {
  const Sector& s = node.sector();
  int level = field_->levelForSpacing((s.north - s.south) / (opt_.meshSize - 1)); // its rows
  if (node.isCap())
    while (level > 0 && !field_->grid().keysCovering(s, level, kCapHeightKeys))
      --level;
  return level;
}

bool TerrainState::complete(const Node& node) const {
  if (!field_ || reliefOff_) return true;
  if (field_->fadingOver(node.sector())) return false; // a height tile still fading in
  const auto keys = field_->grid().keysCovering(
      node.sector(), heightLevelFor(node), node.isCap() ? kCapHeightKeys : 16);
  if (!keys) return true;
  return std::all_of(
      keys->begin(), keys->end(), [&](const TileKey& k) { return heights_->settled(k, *field_); });
}

} // namespace tellus::planet
