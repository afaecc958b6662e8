#pragma once
/**
 * @file Commands.hpp
 * @brief The commands of `tellus`, one file each (Seed.cpp, Cache.cpp, Serve.cpp, Render.cpp,
 * View.cpp, Height.cpp), and what they share (Shared.cpp, PlanetTiles.cpp), as they were in
 * main.cpp.
 */

#include <tellus/cache/TileCache.hpp>
#include <tellus/cache/TileGrid.hpp>
#include <tellus/cli/ProxyFromConfig.hpp>
#include <tellus/cli/Values.hpp>
#include <tellus/config/CommandLine.hpp>
#include <tellus/config/Config.hpp>
#include <tellus/proxy/TileService.hpp>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace tellus::commands {

inline constexpr int kExitOk = 0;
inline constexpr int kExitError = 1;
inline constexpr int kExitUsage = 2;
inline constexpr int kExitProblems = 3;
inline constexpr int kExitCacheFull = 4; // seed: the cache refused tiles for lack of space

extern const char* const kUsage;

using cli::Args;

using cli::humanBytes;
using cli::parseBbox;
using cli::parseDuration;
using cli::parseLevels;
using cli::parseNumbers;
using cli::parseSize;
using cli::proxySpecs;

std::filesystem::path dataDir(const Args& a);
std::string jsonString(std::string_view s);

struct Context {
  Config config;
  std::unique_ptr<TileCache> cache;
};

std::size_t descriptorBudget(int maxConnections);
std::optional<Context> setUp(const Args& a, bool seeding = false, bool serving = false);

int cmdSeed(const Args& a);
int cmdCache(const Args& a);
std::optional<std::string> checkCacheSubcommand(const Args& a);
int cmdServe(const Args& a);
int cmdRender(const Args& a);
int cmdView(const Args& a);
int cmdHeight(const Args& a);

} // namespace tellus::commands
