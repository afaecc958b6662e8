#pragma once
/**
 * @file TimePrefetch.hpp
 * @brief Fetching ahead for time that plays (issue 24): while a layer shows one time, the tiles
 * its drawn nodes will need at the next few times of its animation (TimeAnimation::ahead) are
 * asked of the tile source at a priority below every visible tile's, so that the source (the
 * in-process tile service, or a remote `tellus serve`) has them in its cache when the layer
 * switches: the pending time's own streamer then finds them there and the swap comes sooner.
 * The bytes are not kept here (the cache keeps them): what is ahead costs no texture memory.
 *
 * Bounded: at most maxInFlight requests out at once (the bytes in flight are at most that many
 * tiles), nearer times first, each time's tiles in draw-list order; a tile asked once for a time
 * is not asked again while that time stays ahead. Requests for times no longer ahead are
 * cancelled, and what is remembered of them dropped (at most the draw list's tiles for each time
 * ahead are remembered). GL-free; main thread only, callbacks only push into a locked inbox.
 */

#include <tellus/cache/TileSource.hpp>
#include <tellus/planet/NodeTiles.hpp>
#include <tellus/planet/Quadtree.hpp>

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <unordered_map>

namespace tellus::planet {

struct PrefetchParams {
  std::string layer;
  std::size_t maxInFlight = 4; ///< requests out at once (>= 1)
  /** The requests' priority: below the streamers' (their scores are positive areas). */
  double priority = -1.0;
};

struct PrefetchStats {
  std::size_t requested = 0; ///< totals
  std::size_t received = 0;  ///< Ok answers
  std::size_t absent = 0;
  std::size_t failed = 0;
  std::size_t cancelled = 0;
  std::size_t bytes = 0;           ///< of the Ok answers (then dropped)
  std::size_t inFlight = 0;        ///< now
  std::size_t maxInFlightSeen = 0; ///< the most out at once
  /** The last update: tiles of the drawn nodes at the times ahead, and how many of them were
   * answered (a time ahead is ready in the source's cache when they are equal). */
  std::size_t wanted = 0;
  std::size_t settled = 0;
};

class TimePrefetcher {
public:
  TimePrefetcher(ITileSource& source, PrefetchParams params);
  /** Cancels what is still queued; a callback still running finds nothing to write into. */
  ~TimePrefetcher();
  TimePrefetcher(const TimePrefetcher&) = delete;
  TimePrefetcher& operator=(const TimePrefetcher&) = delete;

  /** One frame: answers taken in, requests of times no longer in `times` cancelled, then the
   * drawn nodes' tiles (tree.drawList()) at each time of `times`, in order, asked for while
   * there is room. */
  void update(const Quadtree& tree, std::span<const std::string> times);
  const PrefetchStats& stats() const noexcept { return stats_; }
  /** The layer streamer's tiles of a node (a cap may be one whole row, NodeTiles.hpp). A whole
   * row or span that fails here turns them off as in the streamer (NodeTiles::refused). */
  void setNodeTiles(NodeTiles tiles) noexcept {
    nodeTiles_ = std::move(tiles);
    nodeTiles_.absent.clear(); // the streamer's time's: other times may have them
  }
  /** What the streamer has turned off since (its fallback) is off here too. */
  void followNodeTiles(const NodeTiles& streamer) noexcept { nodeTiles_.narrowTo(streamer); }
  const NodeTiles& nodeTiles() const noexcept { return nodeTiles_; }

private:
  struct Entry {
    TileRequestId id = 0;
    std::uint64_t token = 0;
    bool open = true; ///< asked, not answered
  };
  struct Inbox;
  using TimeTiles = std::unordered_map<TileKey, Entry, TileKeyHash>;
  void drain();

  ITileSource& source_;
  PrefetchParams params_;
  NodeTiles nodeTiles_;
  std::shared_ptr<Inbox> inbox_;
  std::map<std::string, TimeTiles> times_; ///< per time ahead, its tiles asked for
  std::unordered_map<std::uint64_t, std::pair<std::string, TileKey>> byToken_;
  std::uint64_t nextToken_ = 1;
  PrefetchStats stats_;
};

} // namespace tellus::planet
