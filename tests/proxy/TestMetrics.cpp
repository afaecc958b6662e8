#include <tellus/proxy/Metrics.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <sstream>
#include <string>

using namespace tellus;

namespace {

/** Sample lines of an exposition, "name{labels}" -> value; fails the test on a malformed line. */
std::map<std::string, double> samples(const std::string& text) {
  std::map<std::string, double> out;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty()) {
      ADD_FAILURE() << "empty line in the exposition";
      continue;
    }
    if (line.starts_with("# HELP ") || line.starts_with("# TYPE ")) continue;
    const auto space = line.rfind(' ');
    if (space == std::string::npos || line.front() == '#') {
      ADD_FAILURE() << "malformed line: " << line;
      continue;
    }
    const std::string key = line.substr(0, space);
    const std::string value = line.substr(space + 1);
    std::size_t used = 0;
    const double v = std::stod(value, &used);
    EXPECT_EQ(used, value.size()) << line;
    EXPECT_EQ(std::count(key.begin(), key.end(), '{'), std::count(key.begin(), key.end(), '}'))
        << line;
    EXPECT_TRUE(out.emplace(key, v).second) << "duplicate series: " << key;
  }
  return out;
}

} // namespace

TEST(Metrics, CountsRequestsByProtocolAndStatus) {
  ProxyMetrics m({"bluemarble", "etopo"});
  m.requestStarted(Protocol::WorldWind);
  m.requestFinished(Protocol::WorldWind, 200, 1000);
  m.requestStarted(Protocol::WorldWind);
  m.requestFinished(Protocol::WorldWind, 304, 0);
  m.requestStarted(Protocol::Wms);
  m.requestFinished(Protocol::Wms, 418, 12); // not a listed status: "other"
  m.requestStarted(Protocol::Static);        // still in flight
  m.tile(0, TileOutcome::Hit);
  m.tile(0, TileOutcome::Hit);
  m.tile(1, TileOutcome::Miss);
  m.tile(7, TileOutcome::Miss); // no such layer: ignored
  m.composedTiles(6, 0);
  m.composedTiles(2, 4);
  m.composedTexels(65536, 2 * 262144, 0);
  m.composedTexels(0, 0, 262144);        // a 304: nothing returned
  m.composedTexels(65536, 0, 0, 262144); // from a fetch another map started
  const auto s = samples(m.render({}, 4096, 3u << 20));
  EXPECT_EQ(s.at("tellus_http_requests_total{protocol=\"worldwind\",code=\"200\"}"), 1);
  EXPECT_EQ(s.at("tellus_http_requests_total{protocol=\"worldwind\",code=\"304\"}"), 1);
  EXPECT_EQ(s.at("tellus_http_requests_total{protocol=\"wms\",code=\"other\"}"), 1);
  EXPECT_EQ(s.count("tellus_http_requests_total{protocol=\"static\",code=\"200\"}"), 0u);
  EXPECT_EQ(s.at("tellus_http_response_body_bytes_total{protocol=\"worldwind\"}"), 1000);
  EXPECT_EQ(s.at("tellus_http_requests_in_flight{protocol=\"static\"}"), 1);
  EXPECT_EQ(s.at("tellus_http_requests_in_flight{protocol=\"worldwind\"}"), 0);
  EXPECT_EQ(s.at("tellus_tiles_total{layer=\"bluemarble\",result=\"hit\"}"), 2);
  EXPECT_EQ(s.at("tellus_tiles_total{layer=\"etopo\",result=\"miss\"}"), 1);
  EXPECT_EQ(s.at("tellus_tiles_total{layer=\"etopo\",result=\"hit\"}"), 0);
  EXPECT_EQ(s.at("tellus_cache_bytes"), 4096);
  EXPECT_EQ(s.at("tellus_composed_map_tiles_total{source=\"decoded\"}"), 8);
  EXPECT_EQ(s.at("tellus_composed_map_tiles_total{source=\"kept\"}"), 4);
  EXPECT_EQ(s.at("tellus_decoded_tile_cache_bytes"), 3 << 20);
  EXPECT_EQ(s.at("tellus_compose_output_texels_total"), 2 * 65536);
  EXPECT_EQ(s.at("tellus_compose_source_texels_total{origin=\"upstream\"}"), 524288);
  EXPECT_EQ(s.at("tellus_compose_source_texels_total{origin=\"cache\"}"), 262144);
  EXPECT_EQ(s.at("tellus_compose_source_texels_total{origin=\"joined\"}"), 262144);
}

TEST(Metrics, UpstreamHistogramIsCumulativeAndEndsAtItsCount) {
  ProxyMetrics m({});
  UpstreamMetrics u;
  u.name = "gibs \"a\"\\b\nc"; // escaped in the label
  u.stats.requests = 5;
  u.stats.retries = 2;
  u.stats.failures = 1;
  u.stats.errorsByCode[static_cast<std::size_t>(FetchErrc::Timeout)] = 1;
  u.stats.breaker = BreakerState::Open;
  u.stats.latencyBuckets = {0, 1, 1, 2, 3, 3, 3, 4, 4, 4, 4, 4};
  u.stats.latencyCount = 4;
  u.stats.latencySumSeconds = 1.25;
  const std::string text = m.render({u}, std::nullopt);
  const std::string label = "upstream=\"gibs \\\"a\\\"\\\\b\\nc\"";
  const auto s = samples(text);
  EXPECT_EQ(s.at("tellus_upstream_requests_total{" + label + "}"), 5);
  EXPECT_EQ(s.at("tellus_upstream_retries_total{" + label + "}"), 2);
  EXPECT_EQ(s.at("tellus_upstream_errors_total{" + label + ",kind=\"timeout\"}"), 1);
  EXPECT_EQ(s.at("tellus_upstream_breaker_open{" + label + "}"), 1);
  EXPECT_EQ(s.at("tellus_upstream_request_duration_seconds_bucket{" + label + ",le=\"0.01\"}"), 1);
  EXPECT_EQ(s.at("tellus_upstream_request_duration_seconds_bucket{" + label + ",le=\"+Inf\"}"), 4);
  EXPECT_EQ(s.at("tellus_upstream_request_duration_seconds_count{" + label + "}"), 4);
  EXPECT_EQ(s.at("tellus_upstream_request_duration_seconds_sum{" + label + "}"), 1.25);
  EXPECT_EQ(s.count("tellus_cache_bytes"), 0u); // unknown: no sample rather than a wrong one
  EXPECT_NE(text.find("# TYPE tellus_upstream_request_duration_seconds histogram\n"),
            std::string::npos);
}

TEST(Metrics, ABoundedLocalTierShowsItsBytesAndEvictions) {
  ProxyMetrics m({});
  CacheHealthMetrics h;
  EXPECT_EQ(m.render({}, 0, 0, {}, h).find("local_tier"), std::string::npos); // none: no lines
  h.localTier = LocalTierMetrics{123456, 7};
  const auto s = samples(m.render({}, 0, 0, {}, h));
  EXPECT_EQ(s.at("tellus_cache_local_tier_bytes"), 123456);
  EXPECT_EQ(s.at("tellus_cache_local_tier_evictions_total"), 7);
}
