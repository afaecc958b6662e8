#pragma once
/**
 * @file TextureStreamer.hpp
 * @brief Stream order (thesis 4.6): which tiles to ask an ITileSource for, each frame.
 *
 * Candidates are the drawn nodes whose texture is not resident (drawn roots go first; a root that
 * is not drawn is not fetched: what a drawn node lacks shows the global texture, issue 29), and
 * the nearest ancestor of an absent one that may have a texture. A candidate's score is its clipped
 * projected area in pixels (ScreenArea.hpp) times (1 + the levels its displayed texture lacks: own
 * 0, ancestor level difference, global level + 1). A node needs its tiles (one, the
 * textureTileCount(key) tiles of a merged polar node or cap, Quadtree.hpp, or one image of a
 * cap's whole row or a merged node's box, NodeTiles.hpp); a tile takes its best
 * node's score. At most `maxInFlight` requests are out; in-flight requests are re-scored every
 * frame (reprioritize) and cancelled once no candidate wants them. A tile the source calls absent
 * is never asked for again in this session; a failed one waits retryBaseS * 2^(failures - 1)
 * seconds (capped at retryMaxS) before it is asked again, so an offline or dead upstream costs a
 * few requests per tile, never a busy loop.
 *
 * Threads: update(), received() and forget() belong to the main thread; the source's callbacks
 * only push into a locked inbox that update() drains (they may outlive the streamer safely).
 */

#include <tellus/cache/TileSource.hpp>
#include <tellus/planet/Camera.hpp>
#include <tellus/planet/NodeTiles.hpp>
#include <tellus/planet/Quadtree.hpp>
#include <tellus/planet/TextureLru.hpp>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

namespace tellus::planet {

struct StreamParams {
  std::string layer;
  std::string time;
  std::size_t maxInFlight = 8;
  double retryBaseS = 1.0;
  double retryMaxS = 120.0;
};

enum class TileFetch : std::uint8_t {
  Idle,     ///< not asked for (or cancelled, or forgotten)
  InFlight, ///< requested
  Received, ///< bytes handed to the owner through received()
  Absent,   ///< the source says there is none: never asked again
  Failed,   ///< waiting for its retry time
};

struct ReceivedTile {
  TileKey key;
  TileResult result;
};

struct StreamStats {
  std::size_t requested = 0; ///< totals since construction
  std::size_t cancelled = 0;
  std::size_t reprioritized = 0;
  std::size_t received = 0;
  std::size_t absent = 0;
  std::size_t failed = 0;
  std::size_t inFlight = 0;          ///< now
  std::size_t candidates = 0;        ///< nodes wanting a texture in the last update
  std::size_t wholeRowsRefused = 0;  ///< whole rows failed (caps composed since)
  std::size_t wholeSpansRefused = 0; ///< whole spans failed (merged nodes composed since)
};

class TextureStreamer {
public:
  TextureStreamer(ITileSource& source, StreamParams params);
  ~TextureStreamer();
  TextureStreamer(const TextureStreamer&) = delete;
  TextureStreamer& operator=(const TextureStreamer&) = delete;

  /**
   * One frame, after tree.update(camera): drains finished requests, sets the texture state of
   * the drawn nodes (Finished when `resident` holds the node's texture; else from its
   * tiles: Absent when all are absent, CheckingCache while any is in flight, Decoding once all
   * arrived), scores the candidates, cancels, reprioritizes and requests. nowS is a monotonic
   * clock in seconds.
   */
  void update(Quadtree& tree, const Camera& camera, double nowS, const TextureLru* resident);

  /** Tiles that arrived (Ok) since the last call, for the decoder. */
  std::vector<ReceivedTile> takeReceived();
  /** The texture of this node went away (evicted): its tiles may be asked for again. */
  void forget(const NodeKey& key);

  /** The global texture is now an overview `factor` times coarser than level zero: a drawn root
   * it suffices for (overviewSuffices) is no longer a candidate. 0 (the default): none. */
  void setOverviewFactor(double factor) noexcept { overviewFactor_ = factor; }
  double overviewFactor() const noexcept { return overviewFactor_; }

  TileFetch state(const TileKey& key) const noexcept;
  /** Which tiles make a node's texture (a cap: one whole row where the source gives it); set
   * before the first update. A whole row that fails or is absent turns it off for good: caps are
   * then composed of their rows' tiles, and the node shows its parent cap or the global texture
   * until they arrive. */
  void setNodeTiles(NodeTiles tiles) noexcept { nodeTiles_ = std::move(tiles); }
  const NodeTiles& nodeTiles() const noexcept { return nodeTiles_; }
  const StreamStats& stats() const noexcept { return stats_; }
  /** The score the tile was last given (0 when none); for tests and the statistics line. */
  double score(const TileKey& key) const noexcept;

private:
  struct Entry {
    TileFetch state = TileFetch::Idle;
    TileRequestId id = 0;
    std::uint64_t token = 0;
    std::uint64_t wantedFrame = 0;
    double score = 0.0;
    double sentScore = 0.0;
    int failures = 0;
    double retryAtS = 0.0;
  };
  struct Inbox;
  void drain(double nowS);
  /** The texture state of a node from the resident set and its tiles (see update()). */
  void refreshState(Node& node, const TextureLru* resident) const;
  /** Scores the roots and the drawn nodes that need a texture (or an ancestor's) and wants their
   * tiles. */
  void
  wantCandidates(Quadtree& tree, const Camera& camera, double nowS, const TextureLru* resident);
  void
  wantAncestorOf(const Node& node, const Camera& camera, double nowS, const TextureLru* resident);
  void want(const Node& node, double score, double nowS);
  /** Cancels the requests nobody wants any more, re-scores the others, and collects into
   * scratch_ the tiles wanted and not asked for. */
  void settleInFlight();
  /** Asks for the best-scored of scratch_ while there is room in flight. */
  void requestBest();
  void request(const TileKey& key);

  ITileSource& source_;
  StreamParams params_;
  NodeTiles nodeTiles_;
  double overviewFactor_ = 0.0;
  std::shared_ptr<Inbox> inbox_;
  std::unordered_map<TileKey, Entry, TileKeyHash> tiles_;
  std::unordered_map<std::uint64_t, TileKey> byToken_;
  std::vector<std::pair<double, TileKey>> scratch_;
  std::vector<ReceivedTile> received_;
  std::uint64_t frame_ = 0;
  std::uint64_t nextToken_ = 1;
  StreamStats stats_;
};

} // namespace tellus::planet
