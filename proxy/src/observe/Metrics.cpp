#include <tellus/proxy/Metrics.hpp>

#include <cstdio>

namespace tellus {

const char* toString(Protocol p) noexcept {
  switch (p) {
  case Protocol::Wms:
    return "wms";
  case Protocol::WorldWind:
    return "worldwind";
  case Protocol::Static:
    return "static";
  case Protocol::Wmts:
    return "wmts";
  case Protocol::Page:
    return "page";
  case Protocol::Metrics:
    return "metrics";
  case Protocol::Other:
    return "other";
  }
  return "other";
}

const char* toString(TileOutcome o) noexcept {
  switch (o) {
  case TileOutcome::Hit:
    return "hit";
  case TileOutcome::Miss:
    return "miss";
  case TileOutcome::Stale:
    return "stale";
  case TileOutcome::Offline:
    return "offline";
  case TileOutcome::Absent:
    return "absent";
  case TileOutcome::Error:
    return "error";
  case TileOutcome::Refused:
    return "refused";
  }
  return "error";
}

std::string prometheusLabel(std::string_view value) {
  std::string out;
  out.reserve(value.size());
  for (const char c : value) {
    if (c == '\\')
      out += "\\\\";
    else if (c == '"')
      out += "\\\"";
    else if (c == '\n')
      out += "\\n";
    else
      out += c;
  }
  return out;
}

ProxyMetrics::ProxyMetrics(std::vector<std::string> layerNames)
    : layers_(std::move(layerNames)),
      tiles_(std::make_unique<std::array<Counter, kTileOutcomeCount>[]>(layers_.size())) {}

void ProxyMetrics::requestStarted(Protocol p) noexcept {
  inFlight_[static_cast<std::size_t>(p)].fetch_add(1, std::memory_order_relaxed);
}

void ProxyMetrics::requestFinished(Protocol p, int status, std::uint64_t bodyBytes) noexcept {
  const auto pi = static_cast<std::size_t>(p);
  std::size_t slot = kStatuses.size(); // "other"
  for (std::size_t i = 0; i < kStatuses.size(); ++i) {
    if (kStatuses[i] == status) {
      slot = i;
      break;
    }
  }
  requests_[pi][slot].fetch_add(1, std::memory_order_relaxed);
  bytes_[pi].fetch_add(bodyBytes, std::memory_order_relaxed);
  inFlight_[pi].fetch_sub(1, std::memory_order_relaxed);
}

void ProxyMetrics::tile(std::size_t layer, TileOutcome outcome) noexcept {
  if (layer >= layers_.size()) return;
  tiles_[layer][static_cast<std::size_t>(outcome)].fetch_add(1, std::memory_order_relaxed);
}

namespace {

void header(std::string& out, const char* name, const char* type, const char* help) {
  out += "# HELP ";
  out += name;
  out += ' ';
  out += help;
  out += "\n# TYPE ";
  out += name;
  out += ' ';
  out += type;
  out += '\n';
}

std::string metricValue(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

const char* errorName(std::size_t code) {
  return toString(static_cast<FetchErrc>(code));
}

} // namespace

void ProxyMetrics::composedTiles(std::uint64_t decoded, std::uint64_t kept) noexcept {
  composedDecoded_.fetch_add(decoded, std::memory_order_relaxed);
  composedKept_.fetch_add(kept, std::memory_order_relaxed);
}

void ProxyMetrics::composedTexels(std::uint64_t output,
                                  std::uint64_t fromUpstream,
                                  std::uint64_t fromCache,
                                  std::uint64_t joined) noexcept {
  outputTexels_.fetch_add(output, std::memory_order_relaxed);
  upstreamTexels_.fetch_add(fromUpstream, std::memory_order_relaxed);
  cachedTexels_.fetch_add(fromCache, std::memory_order_relaxed);
  joinedTexels_.fetch_add(joined, std::memory_order_relaxed);
}

std::string ProxyMetrics::render(const std::vector<UpstreamMetrics>& upstreams,
                                 std::optional<std::int64_t> cacheBytes,
                                 std::uint64_t decodedTileCacheBytes,
                                 const FetchBudgetMetrics& budget,
                                 const std::optional<CacheHealthMetrics>& cacheHealth) const {
  std::string out;
  out.reserve(4096);
  renderHttp(out);
  renderTiles(out);
  renderUpstreams(out, upstreams);
  renderCache(out, cacheBytes, cacheHealth);
  renderComposer(out, decodedTileCacheBytes);
  renderBudget(out, budget);
  return out;
}

void ProxyMetrics::renderHttp(std::string& out) const {
  header(out,
         "tellus_http_requests_total",
         "counter",
         "HTTP requests answered, by protocol and status code.");
  for (std::size_t p = 0; p < kProtocolCount; ++p) {
    for (std::size_t s = 0; s <= kStatuses.size(); ++s) {
      const auto n = requests_[p][s].load(std::memory_order_relaxed);
      if (n == 0) continue;
      out += "tellus_http_requests_total{protocol=\"";
      out += toString(static_cast<Protocol>(p));
      out += "\",code=\"";
      out += s < kStatuses.size() ? std::to_string(kStatuses[s]) : std::string("other");
      out += "\"} " + std::to_string(n) + "\n";
    }
  }
  header(out,
         "tellus_http_response_body_bytes_total",
         "counter",
         "Bytes of response bodies sent, by protocol.");
  for (std::size_t p = 0; p < kProtocolCount; ++p) {
    out += "tellus_http_response_body_bytes_total{protocol=\"";
    out += toString(static_cast<Protocol>(p));
    out += "\"} " + std::to_string(bytes_[p].load(std::memory_order_relaxed)) + "\n";
  }
  header(out,
         "tellus_http_requests_in_flight",
         "gauge",
         "Requests received and not answered yet, by protocol.");
  for (std::size_t p = 0; p < kProtocolCount; ++p) {
    out += "tellus_http_requests_in_flight{protocol=\"";
    out += toString(static_cast<Protocol>(p));
    out += "\"} " + std::to_string(inFlight_[p].load(std::memory_order_relaxed)) + "\n";
  }
}

void ProxyMetrics::renderTiles(std::string& out) const {
  header(out,
         "tellus_tiles_total",
         "counter",
         "Tile requests by layer and outcome (hit, miss, stale, offline, absent, error, refused: "
         "over the client's fetch budget).");
  for (std::size_t l = 0; l < layers_.size(); ++l) {
    for (std::size_t o = 0; o < kTileOutcomeCount; ++o) {
      out += "tellus_tiles_total{layer=\"" + prometheusLabel(layers_[l]) + "\",result=\"";
      out += toString(static_cast<TileOutcome>(o));
      out += "\"} " + std::to_string(tiles_[l][o].load(std::memory_order_relaxed)) + "\n";
    }
  }
}

void ProxyMetrics::renderUpstreams(std::string& out,
                                   const std::vector<UpstreamMetrics>& upstreams) {
  header(out,
         "tellus_upstream_requests_total",
         "counter",
         "Fetches asked of an upstream (each may take several attempts).");
  for (const auto& u : upstreams) {
    out += "tellus_upstream_requests_total{upstream=\"" + prometheusLabel(u.name) + "\"} " +
           std::to_string(u.stats.requests) + "\n";
  }
  header(out, "tellus_upstream_retries_total", "counter", "Extra attempts after a failure.");
  for (const auto& u : upstreams) {
    out += "tellus_upstream_retries_total{upstream=\"" + prometheusLabel(u.name) + "\"} " +
           std::to_string(u.stats.retries) + "\n";
  }
  header(out,
         "tellus_upstream_errors_total",
         "counter",
         "Fetches that failed, by upstream and kind (timeout, connect, http-error, ...).");
  for (const auto& u : upstreams) {
    for (std::size_t c = 0; c < u.stats.errorsByCode.size(); ++c) {
      if (u.stats.errorsByCode[c] == 0) continue;
      out += "tellus_upstream_errors_total{upstream=\"" + prometheusLabel(u.name) + "\",kind=\"" +
             errorName(c) + "\"} " + std::to_string(u.stats.errorsByCode[c]) + "\n";
    }
  }
  header(out, "tellus_upstream_in_flight", "gauge", "Fetches queued or running.");
  for (const auto& u : upstreams) {
    out += "tellus_upstream_in_flight{upstream=\"" + prometheusLabel(u.name) + "\"} " +
           std::to_string(u.stats.inFlight) + "\n";
  }
  header(out,
         "tellus_upstream_breaker_open",
         "gauge",
         "1 while the upstream's circuit breaker is open or probing, else 0.");
  for (const auto& u : upstreams) {
    out += "tellus_upstream_breaker_open{upstream=\"" + prometheusLabel(u.name) + "\"} " +
           (u.stats.breaker == BreakerState::Closed ? "0" : "1") + "\n";
  }
  header(out,
         "tellus_upstream_request_duration_seconds",
         "histogram",
         "Time from asking an upstream to the end of the fetch, retries included.");
  for (const auto& u : upstreams) {
    const std::string label = prometheusLabel(u.name);
    for (std::size_t i = 0; i < Fetcher::kLatencyBounds.size(); ++i) {
      out += "tellus_upstream_request_duration_seconds_bucket{upstream=\"" + label + "\",le=\"" +
             metricValue(Fetcher::kLatencyBounds[i]) + "\"} " +
             std::to_string(u.stats.latencyBuckets[i]) + "\n";
    }
    out += "tellus_upstream_request_duration_seconds_bucket{upstream=\"" + label +
           "\",le=\"+Inf\"} " + std::to_string(u.stats.latencyBuckets.back()) + "\n";
    out += "tellus_upstream_request_duration_seconds_sum{upstream=\"" + label + "\"} " +
           metricValue(u.stats.latencySumSeconds) + "\n";
    out += "tellus_upstream_request_duration_seconds_count{upstream=\"" + label + "\"} " +
           std::to_string(u.stats.latencyCount) + "\n";
  }
}

void ProxyMetrics::renderCache(std::string& out,
                               std::optional<std::int64_t> cacheBytes,
                               const std::optional<CacheHealthMetrics>& cacheHealth) {
  header(out, "tellus_cache_bytes", "gauge", "Bytes of all cached tiles (from the index).");
  if (cacheBytes) out += "tellus_cache_bytes " + std::to_string(*cacheBytes) + "\n";
  if (cacheHealth) {
    header(out,
           "tellus_cache_writable",
           "gauge",
           "1 while the cache stores fetched tiles, 0 after it refused one for lack of space (disk "
           "or inodes full) until it stores one again.");
    out += std::string("tellus_cache_writable ") + (cacheHealth->writable ? "1" : "0") + "\n";
    header(
        out,
        "tellus_cache_store_refused_total",
        "counter",
        "Fetched tiles the cache did not keep for lack of space (each was served all the same).");
    out += "tellus_cache_store_refused_total " + std::to_string(cacheHealth->refusedStores) + "\n";
    header(out,
           "tellus_cache_kept_unstored_tiles",
           "gauge",
           "Fetched tiles the cache could not store (a full disk, an unreachable shared store), "
           "kept in memory to answer their next requests without the upstream.");
    out +=
        "tellus_cache_kept_unstored_tiles " + std::to_string(cacheHealth->keptUnstoredTiles) + "\n";
    header(out, "tellus_cache_kept_unstored_bytes", "gauge", "Their bytes.");
    out +=
        "tellus_cache_kept_unstored_bytes " + std::to_string(cacheHealth->keptUnstoredBytes) + "\n";
    header(
        out,
        "tellus_cache_kept_unstored_served_total",
        "counter",
        "Tile requests answered from the tiles kept unstored (none of them asked the upstream).");
    out += "tellus_cache_kept_unstored_served_total " +
           std::to_string(cacheHealth->servedKeptUnstored) + "\n";
    header(out,
           "tellus_cache_stored_later_total",
           "counter",
           "Tiles kept unstored that were stored once the cache took tiles again.");
    out += "tellus_cache_stored_later_total " + std::to_string(cacheHealth->storedLater) + "\n";
    if (cacheHealth->sharedIndexUp) {
      header(
          out,
          "tellus_shared_index_up",
          "gauge",
          "1 while the shared PostgreSQL index answers; 0 while it does not: the instance serves "
          "what the tile store holds, read-only, and stores nothing.");
      out +=
          std::string("tellus_shared_index_up ") + (*cacheHealth->sharedIndexUp ? "1" : "0") + "\n";
      header(out,
             "tellus_lease_waits_total",
             "counter",
             "Misses that waited for another instance's fetch of the tile (single flight across "
             "instances) instead of fetching it.");
      out += "tellus_lease_waits_total " + std::to_string(cacheHealth->leaseWaits) + "\n";
      header(out,
             "tellus_served_without_index_total",
             "counter",
             "Tile requests answered from the tile store alone while the shared index was down.");
      out += "tellus_served_without_index_total " +
             std::to_string(cacheHealth->servedWithoutIndex) + "\n";
    }
    if (cacheHealth->freeBytes) {
      header(out,
             "tellus_cache_free_bytes",
             "gauge",
             "Bytes free for tellus on the file system of the cache root.");
      out += "tellus_cache_free_bytes " + std::to_string(*cacheHealth->freeBytes) + "\n";
    }
    if (cacheHealth->freeInodes) {
      header(out,
             "tellus_cache_free_inodes",
             "gauge",
             "Inodes free for tellus on the file system of the cache root.");
      out += "tellus_cache_free_inodes " + std::to_string(*cacheHealth->freeInodes) + "\n";
    }
    if (const auto& tier = cacheHealth->localTier) {
      header(out,
             "tellus_cache_local_tier_bytes",
             "gauge",
             "Bytes of the local copies in front of the shared store (cache.s3.local_tier_limit "
             "bounds them).");
      out += "tellus_cache_local_tier_bytes " + std::to_string(tier->bytes) + "\n";
      header(out,
             "tellus_cache_local_tier_evictions_total",
             "counter",
             "Local copies removed to stay under cache.s3.local_tier_limit (the shared store keeps "
             "them).");
      out += "tellus_cache_local_tier_evictions_total " + std::to_string(tier->evictions) + "\n";
    }
  }
}

void ProxyMetrics::renderComposer(std::string& out, std::uint64_t decodedTileCacheBytes) const {
  header(
      out,
      "tellus_composed_map_tiles_total",
      "counter",
      "Tiles sampled by composed GetMaps: decoded for the map, or kept decoded from earlier maps "
      "(server.limits.decoded_tile_cache).");
  out += "tellus_composed_map_tiles_total{source=\"decoded\"} " +
         std::to_string(composedDecoded_.load(std::memory_order_relaxed)) + "\n";
  out += "tellus_composed_map_tiles_total{source=\"kept\"} " +
         std::to_string(composedKept_.load(std::memory_order_relaxed)) + "\n";
  header(out,
         "tellus_compose_output_texels_total",
         "counter",
         "Pixels of the composed GetMaps and WMTS tiles answered (width x height).");
  out += "tellus_compose_output_texels_total " +
         std::to_string(outputTexels_.load(std::memory_order_relaxed)) + "\n";
  header(out,
         "tellus_compose_source_texels_total",
         "counter",
         "Texels of the tiles composed answers were made from: fetched from the upstream for the "
         "answer, found in the cache, or fetched for another answer whose fetch it joined in "
         "flight (each upstream fetch counted once as upstream).");
  out += "tellus_compose_source_texels_total{origin=\"upstream\"} " +
         std::to_string(upstreamTexels_.load(std::memory_order_relaxed)) + "\n";
  out += "tellus_compose_source_texels_total{origin=\"cache\"} " +
         std::to_string(cachedTexels_.load(std::memory_order_relaxed)) + "\n";
  out += "tellus_compose_source_texels_total{origin=\"joined\"} " +
         std::to_string(joinedTexels_.load(std::memory_order_relaxed)) + "\n";
  header(out,
         "tellus_decoded_tile_cache_bytes",
         "gauge",
         "Bytes of decoded tiles kept for composed GetMaps.");
  out += "tellus_decoded_tile_cache_bytes " + std::to_string(decodedTileCacheBytes) + "\n";
}

void ProxyMetrics::renderBudget(std::string& out, const FetchBudgetMetrics& budget) {
  header(out,
         "tellus_client_fetch_budget_per_minute",
         "gauge",
         "Upstream fetches one client address may cause per minute (0: unlimited; "
         "server.limits.fetches_per_client_per_minute).");
  out += "tellus_client_fetch_budget_per_minute " + metricValue(budget.perMinute) + "\n";
  header(out,
         "tellus_client_fetch_budget_refused_total",
         "counter",
         "Upstream fetches refused because the client's budget was spent (answered 429).");
  out += "tellus_client_fetch_budget_refused_total " + std::to_string(budget.refused) + "\n";
  header(out,
         "tellus_client_fetch_budget_clients",
         "gauge",
         "Client addresses whose fetch budget is being tracked.");
  out += "tellus_client_fetch_budget_clients " + std::to_string(budget.clients) + "\n";
}

} // namespace tellus
