#pragma once
// Shared fixtures of the cache tests: a dataset spec, deterministic tile bytes, an opened cache.

#include <tellus/cache/TileCache.hpp>

#include <gtest/gtest.h>

#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace tellus::test {

/** A World Wind style imagery dataset: 36-degree level zero, 512-pixel JPEG, 12 levels. */
inline DatasetSpec imagerySpec(const std::string& name = "bluemarble") {
  DatasetSpec s;
  s.server = "local";
  s.name = name;
  s.grid = GridSpec{Sector{}, 36.0, 512, 512, 12};
  s.mimeType = "image/jpeg";
  s.extension = "jpg";
  return s;
}

/** Content that depends on the key: its length is base plus up to 96 bytes, its bytes a pattern. */
inline std::vector<std::byte> payload(const TileKey& k, std::size_t base = 100) {
  const std::size_t n = base + static_cast<std::size_t>((k.row * 7 + k.col * 13 + k.level) % 97);
  std::vector<std::byte> v(n);
  for (std::size_t i = 0; i < n; ++i) {
    v[i] = static_cast<std::byte>(
        (static_cast<std::size_t>(k.row) * 31 + static_cast<std::size_t>(k.col) + i) & 0xFF);
  }
  return v;
}

/** Opens a cache for a test (no fsync: tests need no durability across power loss). */
inline std::unique_ptr<TileCache> openTestCache(const std::filesystem::path& root,
                                                std::uint64_t sizeLimitBytes = 0,
                                                bool fsyncTiles = false) {
  TileCache::Options o;
  o.root = root;
  o.sizeLimitBytes = sizeLimitBytes;
  o.fsyncTiles = fsyncTiles;
  auto c = TileCache::open(o);
  EXPECT_TRUE(c) << (c ? "" : c.error().message);
  return c ? std::move(*c) : nullptr;
}

} // namespace tellus::test
