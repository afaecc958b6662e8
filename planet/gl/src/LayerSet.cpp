#include "LayerSet.hpp"

#include <tellus/planet/TextureFallback.hpp>

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <utility>

namespace tellus::planet {

bool LayerTextures::idle() const {
  return streamer->stats().inFlight == 0 && decoding.empty() && uploading.empty();
}

bool LayerTextures::done(const Node& n) const {
  const auto own = [&](const Node& x) {
    return x.texture == TextureState::Finished || undecodable.contains(x.key());
  };
  if (own(n)) return true;
  if (overviewSuffices(n, overviewFactor)) return true;
  if (n.texture != TextureState::Absent) return false;
  for (const Node* a = n.parent(); a != nullptr; a = a->parent())
    if (a->texture != TextureState::Absent) return own(*a);
  return true;
}

void LayerTextures::install(const NodeKey& key, NodeTexture texture, std::size_t bytes) {
  if (auto old = textures.find(key); old != textures.end()) pool.release(std::move(old->second));
  texture.shownSinceS = std::numeric_limits<double>::quiet_NaN(); // fades in when first drawn
  textures[key] = std::move(texture);
  lru.insert(key, bytes);
  uploading.erase(key);
}

std::size_t LayerTextures::evict() {
  const auto evicted = lru.takeEvicted();
  if (evicted.empty()) return 0;
  std::unordered_set<NodeKey, NodeKeyHash> gone;
  for (const NodeKey& k : evicted) {
    if (auto it = textures.find(k); it != textures.end()) {
      pool.release(std::move(it->second));
      textures.erase(it);
    }
    streamer->forget(k);
    gone.insert(k);
  }
  tree->forEach([&](Node& n) {
    if (n.texture == TextureState::Finished && gone.contains(n.key()))
      n.texture = TextureState::NoTexture;
  });
  return evicted.size();
}

bool LayerTextures::ready() const {
  if (!updated || tree->drawList().empty()) return false;
  const auto settled = [&](const Node& n) {
    if (done(n)) return true;
    if (uploading.contains(n.key()) || decoding.contains(n.key())) return false;
    const NodeTiles& tiles = streamer->nodeTiles();
    for (std::int64_t i = 0; i < tiles.count(n.key()); ++i)
      if (streamer->state(tiles.tile(n.key(), i)) == TileFetch::Failed) return true;
    return false;
  };
  for (const Node* n : tree->drawList())
    if (!settled(*n)) return false;
  return true;
}

void LayerSlot::dropPending() {
  if (!pending) return;
  retiredRequested += pending->streamer->stats().requested;
  retiredReceived += pending->streamer->stats().received;
  pending.reset();
}

LayerSet::LayerSet(ITileSource& source,
                   const Geodesy& geodesy,
                   const RendererOptions& options,
                   TileGrid baseGrid)
    : source_(source), geodesy_(geodesy), options_(options), baseGrid_(baseGrid) {}

std::expected<void, std::string> LayerSet::open() {
  LayerSlot base;
  base.opt.layer = options_.layer;
  base.opt.time = options_.time;
  auto made = makeFor(base, base.opt.time, false, -1);
  if (!made) return std::unexpected(made.error());
  base.current = std::move(*made);
  slots_.push_back(std::move(base));
  for (const LayerOptions& o : options_.overlays) {
    LayerSlot slot;
    slot.opt = o;
    auto l = makeFor(slot, o.time, true, o.maxLevel);
    if (!l) return std::unexpected(l.error());
    slot.current = std::move(*l);
    slots_.push_back(std::move(slot));
  }
  return {};
}

std::expected<std::unique_ptr<LayerTextures>, std::string>
LayerSet::make(const std::string& name, const std::string& time, bool overlay, int maxLevel) {
  const auto spec = source_.describe(name, time);
  if (!spec) return std::unexpected("unknown layer '" + name + "'");
  GridSpec gs = spec->grid;
  if (maxLevel >= 0) gs.numLevels = std::min(gs.numLevels, maxLevel + 1);
  auto g = TileGrid::create(gs);
  if (!g) return std::unexpected("layer '" + name + "': " + g.error());
  if (overlay && gs.levelZeroDeltaDeg != baseGrid_.spec().levelZeroDeltaDeg)
    return std::unexpected("overlay '" + name + "' has " + std::to_string(gs.levelZeroDeltaDeg) +
                           "-degree level-zero tiles, the base layer " +
                           std::to_string(baseGrid_.spec().levelZeroDeltaDeg) +
                           ": an overlay must share the base layer's grid");
  const std::size_t share = options_.textureBudgetBytes / (1 + options_.overlays.size());
  auto l = std::make_unique<LayerTextures>(*g, std::max<std::size_t>(share, 1));
  l->tag = nextTag_++;
  l->layer = name;
  l->time = time;
  l->overlay = overlay;
  l->texWidth = gs.tileWidth;
  l->texHeight = gs.tileHeight;
  l->texLevels = nodeTextureLevels(l->texWidth, l->texHeight);
  QuadtreeParams qp;
  qp.lod.tileWidthPx = l->texWidth;
  qp.lod.tileHeightPx = l->texHeight;
  qp.lod.threshold = options_.lodThreshold;
  qp.maxSplitsPerFrame = options_.maxSplitsPerFrame;
  l->tree = std::make_unique<Quadtree>(geodesy_, *g, qp);
  l->chordDepthM = l->tree->chordDepthM(options_.meshSize);
  if (prepare_) prepare_(*l);
  StreamParams sp;
  sp.layer = name;
  sp.time = time;
  sp.maxInFlight = options_.maxInFlight;
  // A cap as one whole row, a merged node as one image of its box, where the source can fetch
  // them (issue 29, docs/design/poles.md).
  l->streamer = std::make_unique<TextureStreamer>(source_, sp);
  if (source_.wholePolarRows(name))
    l->streamer->setNodeTiles(NodeTiles::whole(g->colCount(0), l->tree->capsEnabled()));
  return l;
}

std::expected<std::unique_ptr<LayerTextures>, std::string>
LayerSet::makeFor(const LayerSlot& slot, const std::string& time, bool overlay, int maxLevel) {
  auto l = make(slot.opt.layer, time, overlay, maxLevel);
  if (l && slot.opt.values) (*l)->valueFormat = slot.opt.values->format;
  return l;
}

LayerTextures* LayerSet::byTag(int tag) const {
  for (const LayerSlot& l : slots_) {
    if (l.current && l.current->tag == tag) return l.current.get();
    if (l.pending && l.pending->tag == tag) return l.pending.get();
  }
  return nullptr;
}

std::int32_t LayerSet::levelsFor(const LayerSlot& slot) const {
  const auto spec = source_.describe(slot.opt.layer, slot.current->time);
  if (!spec) return slot.current->grid.numLevels();
  return slot.opt.maxLevel >= 0 ? std::min(spec->grid.numLevels, slot.opt.maxLevel + 1)
                                : spec->grid.numLevels;
}

void LayerSet::setOpacity(std::size_t layer, double opacity) {
  if (layer == 0 || layer >= slots_.size())
    throw std::invalid_argument("only an overlay (layer 1 and up) has an opacity");
  if (!(opacity >= 0.0 && opacity <= 1.0))
    throw std::invalid_argument("the opacity must be in [0, 1]");
  slots_[layer].opt.opacity = opacity;
}

void LayerSet::setVisible(std::size_t layer, bool visible) {
  if (layer == 0 || layer >= slots_.size())
    throw std::invalid_argument("only an overlay (layer 1 and up) can be hidden");
  slots_[layer].opt.visible = visible;
}

void LayerSet::setMaxLevel(std::size_t layer, int maxLevel) {
  if (layer >= slots_.size()) throw std::invalid_argument("no such layer");
  if (maxLevel < -1 || maxLevel > 40)
    throw std::invalid_argument("the maximum level must be -1 (none) or 0 to 40");
  LayerSlot& slot = slots_[layer];
  if (slot.opt.maxLevel == maxLevel) return;
  slot.opt.maxLevel = maxLevel;
  const std::string time = slot.pending ? slot.pending->time : slot.current->time;
  slot.dropPending();
  auto l = makeFor(slot, time, layer > 0, maxLevel);
  if (!l) throw std::invalid_argument(l.error());
  // The same levels (the limit lies past the layer's own) at the same time: nothing to swap.
  if ((*l)->grid.numLevels() == slot.current->grid.numLevels() && time == slot.current->time)
    return;
  slot.pending = std::move(*l);
}

void LayerSet::move(std::size_t from, std::size_t to) {
  if (from == 0 || to == 0 || from >= slots_.size() || to >= slots_.size())
    throw std::invalid_argument("only overlays (layers 1 and up) move");
  const auto at = [this](std::size_t i) { return slots_.begin() + static_cast<std::ptrdiff_t>(i); };
  if (from < to)
    std::rotate(at(from), at(from) + 1, at(to) + 1);
  else if (from > to)
    std::rotate(at(to), at(from), at(from) + 1);
}

void LayerSet::setTime(std::size_t layer, std::string time) {
  if (layer >= slots_.size()) throw std::invalid_argument("no such layer");
  LayerSlot& slot = slots_[layer];
  if (slot.pending && slot.pending->time == time) return;
  slot.dropPending(); // replaced, or cancelled by going back to the current time
  slot.opt.time = time;
  if (time == slot.current->time && slot.current->grid.numLevels() == levelsFor(slot)) return;
  auto l = makeFor(slot, time, layer > 0, slot.opt.maxLevel);
  if (!l) throw std::invalid_argument(l.error());
  slot.pending = std::move(*l);
}

void LayerSet::animate(std::size_t layer, std::optional<TimeAnimation> animation) {
  if (layer >= slots_.size()) throw std::invalid_argument("no such layer");
  LayerSlot& slot = slots_[layer];
  slot.prefetch.reset();
  slot.animation = std::move(animation);
  if (!slot.animation) return;
  PrefetchParams p;
  p.layer = slot.opt.layer;
  p.maxInFlight = slot.animation->options().aheadInFlight;
  slot.prefetch = std::make_unique<TimePrefetcher>(source_, p);
  if (slot.current) slot.prefetch->setNodeTiles(slot.current->streamer->nodeTiles());
}

void LayerSet::swapReady() {
  for (LayerSlot& slot : slots_) {
    if (!slot.pending || !slot.pending->ready()) continue;
    slot.retiredRequested += slot.current->streamer->stats().requested;
    slot.retiredReceived += slot.current->streamer->stats().received;
    slot.current = std::move(slot.pending);
    // A time swaps in all at once (setLayerTime): no texture of it fades in.
    for (auto& [key, texture] : slot.current->textures)
      texture.shownSinceS = -std::numeric_limits<double>::infinity();
    ++slot.swaps;
  }
}

bool LayerSet::idle() const {
  bool idle = true;
  forEach([&](const LayerTextures& l) { idle = idle && l.idle(); });
  return idle;
}

LayerTotals LayerSet::collectStats(RenderStats& stats) const {
  LayerTotals t;
  stats.layers.resize(slots_.size());
  stats.texturesResident = 0;
  stats.textureBytes = 0;
  stats.poolTextures = 0;
  for (std::size_t i = 0; i < slots_.size(); ++i) {
    const LayerSlot& slot = slots_[i];
    RenderStats::Layer& ls = stats.layers[i];
    ls.name = slot.opt.layer;
    ls.time = slot.current->time;
    ls.pendingTime = slot.pending ? slot.pending->time : std::string();
    ls.opacity = slot.opt.opacity;
    ls.visible = slot.opt.visible;
    ls.maxLevel = slot.opt.maxLevel;
    ls.night = slot.opt.night;
    ls.levels = slot.current->grid.numLevels();
    ls.swaps = slot.swaps;
    ls.tilesRequested = slot.retiredRequested;
    ls.tilesReceived = slot.retiredReceived;
    ls.texturesResident = slot.current->lru.count();
    ls.animation.reset();
    if (slot.animation) {
      RenderStats::Layer::Animation& a = ls.animation.emplace();
      a.state = playStateName(slot.animation->state());
      a.target = slot.animation->target();
      a.instants = slot.animation->instants().size();
      a.steps = slot.animation->steps();
      a.heldSteps = slot.animation->heldSteps();
      a.heldSeconds = slot.animation->heldSeconds();
      if (slot.prefetch) {
        const PrefetchStats& p = slot.prefetch->stats();
        a.aheadRequested = p.requested;
        a.aheadReceived = p.received;
        a.aheadInFlight = p.inFlight;
        a.aheadMaxInFlight = p.maxInFlightSeen;
        a.aheadWanted = p.wanted;
        a.aheadSettled = p.settled;
      }
    }
    for (const LayerTextures* l : {slot.current.get(), slot.pending.get()}) {
      if (l == nullptr) continue;
      const StreamStats& st = l->streamer->stats();
      ls.tilesRequested += st.requested;
      ls.tilesReceived += st.received;
      t.stream.requested += st.requested;
      t.stream.received += st.received;
      t.stream.absent += st.absent;
      t.stream.failed += st.failed;
      t.stream.inFlight += st.inFlight;
      t.idle = t.idle && l->idle();
      stats.texturesResident += l->lru.count();
      stats.textureBytes += l->lru.bytes();
      stats.poolTextures += l->pool.size();
    }
    t.stream.requested += slot.retiredRequested;
    t.stream.received += slot.retiredReceived;
  }
  return t;
}

} // namespace tellus::planet
