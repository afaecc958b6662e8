#pragma once
/**
 * @file CacheTileSource.hpp
 * @brief An ITileSource over a TileCache alone, with its own worker threads: offline browsing of
 * what is cached. A tile that is not cached is Absent (there is no upstream to ask).
 */

#include <tellus/cache/TileCache.hpp>
#include <tellus/cache/TileSource.hpp>

#include <memory>

namespace tellus {

class CacheTileSource final : public ITileSource {
public:
  /** Reads through `cache` (which must outlive this source) with `workers` threads (>= 1). With
   * startPaused, nothing runs until start() (tests use it to fill the queue first). */
  CacheTileSource(TileCache& cache, int workers, bool startPaused = false);
  ~CacheTileSource() override;
  CacheTileSource(const CacheTileSource&) = delete;
  CacheTileSource& operator=(const CacheTileSource&) = delete;

  void start();

  std::optional<DatasetSpec> describe(std::string_view layer,
                                      std::string_view time = {}) const override;
  TileRequestId request(const TileAddress& address, double priority, Callback done) override;
  void reprioritize(TileRequestId id, double priority) override;
  bool cancel(TileRequestId id) override;
  /** True when the cache holds `<layer>@caps` (a tile service fetched polar rows whole, issue
   * 29): they are read from there; one that is not is Absent, and the renderer then composes the
   * caps of their rows' tiles. */
  bool wholePolarRows(std::string_view layer) const override;

  /** Requests queued and not yet started. */
  std::size_t queued() const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

} // namespace tellus
