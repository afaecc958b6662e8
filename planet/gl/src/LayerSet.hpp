#pragma once
/**
 * @file LayerSet.hpp
 * @brief The layers a renderer draws (issue #7): the base imagery and the overlays in drawing
 * order, each a LayerSlot (the user's settings, its textures at the current time, and those of a
 * time or level limit it is switching to, swapped in whole once ready).
 *
 * A LayerTextures is one layer at one time: its own tree (LOD and stream order in its grid, the
 * same camera as the base), its streamer, the tiles received and waiting for their node's decode,
 * the decodes and uploads in flight, its resident textures (the LRU) and its pool. The base
 * layer's tree is also the geometry every layer is drawn on (geo()). Destroying a LayerTextures
 * deletes its GL textures: the context must be current (GlObjects.hpp); one that never made a
 * texture (GL-free tests) calls no GL function. Main thread only.
 *
 * The phases that work on layers are elsewhere: FrameUpdate (trees and streaming), TextureIntake
 * (received tiles, decodes), UploadQueue (uploads), DrawList (what is drawn); here are the set
 * itself, the users' changes, the swaps and the evictions.
 */

#include "NodeTextures.hpp"

#include <tellus/cache/TileSource.hpp>
#include <tellus/planet/Quadtree.hpp>
#include <tellus/planet/TextureLru.hpp>
#include <tellus/planet/TextureStreamer.hpp>
#include <tellus/planet/TimeAnimation.hpp>
#include <tellus/planet/TimePrefetch.hpp>
#include <tellus/planet_gl/Renderer.hpp>
#include <tellus/values/ColourScale.hpp>

#include <cstddef>
#include <cstdint>
#include <expected>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace tellus::planet {

/** A tile's bytes kept until its node is decoded, and the frame it arrived in. */
struct StoredTile {
  std::vector<std::byte> bytes;
  std::string contentType;
  std::uint64_t frame = 0;
};

/** One layer at one time (see the file comment). */
struct LayerTextures {
  int tag = 0; ///< unique for the renderer's life (decode jobs and uploads carry it)
  std::string layer;
  std::string time;
  bool overlay = false;
  /** A layer of values (LayerOptions::values): its tiles decoded as floats (ValueTexture.hpp). */
  std::optional<values::ValueFormat> valueFormat;
  TileGrid grid;
  int texWidth = 0, texHeight = 0; ///< the grid's tile size: its node textures' size
  int texLevels = 1;
  std::unique_ptr<Quadtree> tree;
  std::unique_ptr<TextureStreamer> streamer;
  /** The global texture is an overview this many times coarser than level zero (Overview.hpp):
   * a root it suffices for is done (overviewSuffices). 0: none (or not composed yet). */
  double overviewFactor = 0.0;
  TextureLru lru;
  std::unordered_map<NodeKey, NodeTexture, NodeKeyHash> textures; ///< resident, drawable
  TexturePool pool;
  std::unordered_map<TileKey, StoredTile, TileKeyHash> received;
  std::unordered_set<NodeKey, NodeKeyHash> decoding;
  std::unordered_set<NodeKey, NodeKeyHash> uploading;
  std::unordered_set<NodeKey, NodeKeyHash> undecodable;
  bool updated = false; ///< its tree was updated this frame (FrameUpdate)
  /** How far its meshes' triangles reach below the ellipsoid (its roots' chords, the coarsest):
   * the horizon occluder sits that much lower (TerrainState::applyTo). */
  double chordDepthM = 0.0;

  LayerTextures(TileGrid g, std::size_t budget) : grid(g), lru(budget) {}
  /** Nothing in flight, decoding or uploading. */
  bool idle() const;
  /** The node shows what it will show: its own texture, or none exists (absent, undecodable)
   * and its nearest ancestor that is not absent shows its own. */
  bool done(const Node& n) const;
  /** A finished upload: the key's texture (the one it replaces goes to the pool), in the LRU,
   * drawable from the next frame. */
  void install(const NodeKey& key, NodeTexture texture, std::size_t bytes);
  /** Textures the LRU let go: back to the pool, their tiles may be fetched again, and any node
   * still marked Finished for them falls back from now on. How many went. */
  std::size_t evict();
  /** A new time is ready when every node its LOD draws has its texture, or has
   * none to get (absent, undecodable, or its fetch failed and waits for a retry: a dead upstream
   * must not hold the old time forever). */
  bool ready() const;
};

/** A layer as the user sees it: its settings, its textures at the current time, and those of a
 * time it is switching to (swapped in whole once ready). */
struct LayerSlot {
  LayerOptions opt;
  std::unique_ptr<LayerTextures> current;
  std::unique_ptr<LayerTextures> pending;
  /** A layer of values with `range: data`: the range of the values its drawn nodes show, as
   * planDraw last found it (nullopt: none yet). */
  std::optional<values::ValueRange> dataRange;
  std::size_t swaps = 0;
  std::size_t retiredRequested = 0; ///< tiles of times no longer drawn
  std::size_t retiredReceived = 0;
  /** Time that plays (issue 24; LayerAnimation.hpp): the layer's animation and what fetches its
   * next times ahead; none when not animated. */
  std::optional<TimeAnimation> animation;
  std::unique_ptr<TimePrefetcher> prefetch;
  /** Drops the pending textures (their tiles counted as retired). */
  void dropPending();
};

/** What the layers' streamers did, summed, and whether any layer has work in flight. */
struct LayerTotals {
  StreamStats stream;
  bool idle = true;
};

class LayerSet {
public:
  /** Sets up a new layer's tree before it streams (the terrain's heights and horizon occluder:
   * TerrainState::applyTo); may be empty. */
  using Prepare = std::function<void(LayerTextures&)>;

  /** The options give each layer's tree and streamer parameters and the texture budget's share
   * (the budget over the base and the overlays); baseGrid is the base layer's grid, which every
   * overlay's level-zero tiles must match. The source and geodesy must outlive the set. */
  LayerSet(ITileSource& source,
           const Geodesy& geodesy,
           const RendererOptions& options,
           TileGrid baseGrid);
  void setPrepare(Prepare prepare) { prepare_ = std::move(prepare); }
  /** The base layer and the options' overlays; fails with a message (unknown layer, a grid that
   * does not match the base's). */
  std::expected<void, std::string> open();
  /** A layer at a time: its grid (up to maxLevel, -1: all), its tree with the base's LOD settings
   * and its own tile size, its streamer, and its share of the texture budget. */
  std::expected<std::unique_ptr<LayerTextures>, std::string>
  make(const std::string& name, const std::string& time, bool overlay, int maxLevel);
  /** make() for the slot's layer (its values' format too). */
  std::expected<std::unique_ptr<LayerTextures>, std::string>
  makeFor(const LayerSlot& slot, const std::string& time, bool overlay, int maxLevel);

  std::size_t size() const noexcept { return slots_.size(); }
  LayerSlot& operator[](std::size_t i) { return slots_[i]; }
  const LayerSlot& operator[](std::size_t i) const { return slots_[i]; }
  std::vector<LayerSlot>& slots() noexcept { return slots_; }
  const std::vector<LayerSlot>& slots() const noexcept { return slots_; }
  /** The base layer at its current time; its tree is what is drawn. */
  LayerTextures& base() const { return *slots_.front().current; }
  Quadtree& geo() const { return *base().tree; }
  /** The layer (current or pending) a decode job or upload was made for; null once swapped out. */
  LayerTextures* byTag(int tag) const;
  /** f(LayerTextures&) for every layer at every time: slot order, current before pending. */
  template <class F> void forEach(F&& f) const {
    for (const LayerSlot& s : slots_)
      for (LayerTextures* l : {s.current.get(), s.pending.get()})
        if (l != nullptr) f(*l);
  }

  /** The user's changes (Renderer's setLayer*, moveLayer): refused with std::invalid_argument as
   * Renderer.hpp says. Time and level changes make a pending LayerTextures (swapped in by
   * swapReady); dropping one deletes its textures, so the context must be current. */
  void setOpacity(std::size_t layer, double opacity);
  void setVisible(std::size_t layer, bool visible);
  void setTime(std::size_t layer, std::string time);
  void setMaxLevel(std::size_t layer, int maxLevel);
  void move(std::size_t from, std::size_t to);
  /** Plays the layer's time (LayerAnimation.hpp), replacing an animation it had; nullopt stops
   * it (the layer keeps the time it shows). */
  void animate(std::size_t layer, std::optional<TimeAnimation> animation);

  /** A layer whose pending time is ready swaps to it, all at once, for the next frame. */
  void swapReady();
  /** Nothing in flight, decoding or uploading in any layer. */
  bool idle() const;
  /** Fills stats.layers (per layer) and the resident texture counts; the streams' totals. */
  LayerTotals collectStats(RenderStats& stats) const;

private:
  /** The levels a slot's layer has under its maximum level (what a fresh LayerTextures gets). */
  std::int32_t levelsFor(const LayerSlot& slot) const;

  ITileSource& source_;
  const Geodesy& geodesy_;
  const RendererOptions& options_;
  TileGrid baseGrid_;
  Prepare prepare_;
  std::vector<LayerSlot> slots_; ///< [0] the base imagery, then the overlays in drawing order
  int nextTag_ = 1;
};

} // namespace tellus::planet
