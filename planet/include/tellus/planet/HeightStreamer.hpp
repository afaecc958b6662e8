#pragma once
/**
 * @file HeightStreamer.hpp
 * @brief Elevation tiles through the tile source (issue #6): requested coarse first with a window
 * in flight, decoded into metres on the source's worker thread (the callback), handed to the
 * HeightField on the main thread a few per frame so the meshes they change can all be rebuilt in
 * that frame. GL-free.
 */

#include <tellus/cache/TileSource.hpp>
#include <tellus/planet/Terrain.hpp>

#include <cstddef>
#include <cstdint>
#include <deque>
#include <expected>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

namespace tellus::planet {

/** Bytes of one elevation tile to metres (runs on a worker thread: must be thread safe). */
using HeightDecoder =
    std::function<std::expected<HeightTile, std::string>(const TileKey& key,
                                                         int width,
                                                         int height,
                                                         std::span<const std::byte> bytes,
                                                         std::string_view contentType,
                                                         const HeightEncoding& encoding)>;

/** BIL16 (application/bil16, or bytes of exactly width x height x 2); anything else an error. */
std::expected<HeightTile, std::string> decodeHeightsBil16Only(const TileKey& key,
                                                              int width,
                                                              int height,
                                                              std::span<const std::byte> bytes,
                                                              std::string_view contentType,
                                                              const HeightEncoding& encoding);

struct HeightStreamParams {
  std::string layer;
  std::string time;
  std::size_t maxInFlight = 8;
  HeightEncoding encoding{};
  double retryAfterS = 5.0; ///< a failed tile is asked again after this long
  /** Applied to every decoded tile on the worker thread (applyVerticalDatum): mean-sea-level
   * heights onto the ellipsoid with the geoid (`renderer.geoid`); off by default (h = H). */
  VerticalDatum datum{};
};

struct HeightStreamStats {
  std::size_t requested = 0;
  std::size_t received = 0;
  std::size_t absent = 0;
  std::size_t failed = 0;
  std::size_t decodeErrors = 0;
  std::size_t inFlight = 0;
  std::size_t waiting = 0; ///< decoded, not yet in the field
};

/** Not thread safe except for the source's callbacks (which only fill an inbox). */
class HeightStreamer {
public:
  HeightStreamer(ITileSource& source,
                 const TileGrid& grid,
                 HeightStreamParams params,
                 HeightDecoder decode = decodeHeightsBil16Only);
  ~HeightStreamer();
  HeightStreamer(const HeightStreamer&) = delete;
  HeightStreamer& operator=(const HeightStreamer&) = delete;

  /** This frame's wish list, most important first: requests what is not held, absent, in flight
   * or waiting for its retry, up to the window; queued requests no longer wished for are
   * cancelled. */
  void want(std::span<const TileKey> keys, const HeightField& field, double nowS);
  /** Moves up to maxTiles decoded tiles into the field; returns how many. */
  std::size_t deliver(HeightField& field, std::size_t maxTiles);
  /** Held by the field, absent, or failed (for now): nothing more will come for it soon. */
  bool settled(const TileKey& key, const HeightField& field) const;
  bool busy() const;
  const HeightStreamStats& stats() const noexcept { return stats_; }

private:
  struct Inbox {
    std::mutex mutex;
    std::deque<std::pair<TileKey, std::expected<HeightTile, std::string>>> done;
    std::vector<TileKey> absent;
    std::vector<std::pair<TileKey, std::string>> failed;
  };
  void drain(double nowS);
  ITileSource& source_;
  TileGrid grid_;
  HeightStreamParams params_;
  HeightDecoder decode_;
  std::shared_ptr<Inbox> inbox_;
  std::unordered_map<TileKey, TileRequestId, TileKeyHash> inFlight_;
  std::unordered_map<TileKey, double, TileKeyHash> retryAt_;
  std::unordered_map<TileKey, bool, TileKeyHash> absent_;
  std::deque<std::pair<TileKey, HeightTile>> ready_;
  HeightStreamStats stats_;
};

} // namespace tellus::planet
