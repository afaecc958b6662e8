#pragma once
/**
 * @file RemoteTileSource.hpp
 * @brief An ITileSource over HTTP to a remote `tellus serve`: what the planet renderer uses when
 * the cache lives on another machine (`tellus render --server URL`).
 *
 * The layers and their grids come from the server's `/layers.json`, read once by connect().
 * Tiles are GETs of `/tiles/<layer>/<level>/<row>/<row>_<col>.<ext>[?time=T]` (served from the
 * remote cache with sendfile: 200 bytes, 404 absent, 502 failed upstream, 400 a TIME the layer
 * does not have). Requests wait in a priority queue (highest first) and at most
 * `maxInFlight` are on the wire, so reprioritize() and cancel() still matter for the queued ones;
 * transport (timeouts, retries with backoff, the circuit breaker) is the proxy's Fetcher.
 */

#include <tellus/cache/TileSource.hpp>

#include <chrono>
#include <cstddef>
#include <expected>
#include <memory>
#include <string>
#include <vector>

namespace tellus {

struct RemoteSourceOptions {
  std::size_t maxInFlight = 6; ///< requests on the wire at once (browsers use 6 per host)
  std::chrono::milliseconds connectTimeout{3000};
  std::chrono::milliseconds timeout{20000}; ///< one attempt
  int retries = 1;
};

/** One layer as /layers.json describes it (what describe() builds its DatasetSpec from). */
struct RemoteLayer {
  std::string name;
  DatasetSpec dataset;
  bool elevation = false;
  /** The server gives its polar rows and spans whole (`"wholeRows"`, issue 29). */
  bool wholeRows = false;
};

/** Parses a tellus `/layers.json` document (the format of proxy/src/web/WebPage.cpp's layersJson);
 * `server` becomes each dataset's server name. Strict JSON (nlohmann-json: UTF-8, no NUL byte,
 * nested at most 32 deep); unknown members are ignored. An error names what is wrong, and for text
 * that is not JSON the offset where it stops being JSON. */
std::expected<std::vector<RemoteLayer>, std::string> parseLayersJson(std::string_view json,
                                                                     std::string_view server);

class RemoteTileSource final : public ITileSource {
public:
  /** Reads `<baseUrl>/layers.json` (baseUrl: http://host:port, no trailing path needed). Fails
   * with a message naming the URL when the server cannot be reached or answers something else. */
  static std::expected<std::unique_ptr<RemoteTileSource>, std::string>
  connect(const std::string& baseUrl, RemoteSourceOptions options = {});
  ~RemoteTileSource() override;
  RemoteTileSource(const RemoteTileSource&) = delete;
  RemoteTileSource& operator=(const RemoteTileSource&) = delete;

  const std::vector<RemoteLayer>& layers() const noexcept;

  std::optional<DatasetSpec> describe(std::string_view layer,
                                      std::string_view time = {}) const override;
  TileRequestId request(const TileAddress& address, double priority, Callback done) override;
  void reprioritize(TileRequestId id, double priority) override;
  bool cancel(TileRequestId id) override;
  /** What the server's /layers.json says (`"wholeRows"`): `<layer>@caps` and `<layer>@span<k>`
   * are then `/tiles/<layer>@caps/...` and `/tiles/<layer>@span<k>/...`. */
  bool wholePolarRows(std::string_view layer) const override;

  /** The URL a tile is fetched from (for tests and logs); empty for an unknown layer. */
  std::string tileUrl(const TileAddress& address) const;
  /** Requests queued, not yet on the wire. */
  std::size_t queued() const;

private:
  struct Impl;
  explicit RemoteTileSource(std::shared_ptr<Impl> impl);
  std::shared_ptr<Impl> impl_;
};

} // namespace tellus
