#pragma once
/**
 * @file Values.hpp
 * @brief The values of `tellus` options (what follows `--levels`, `--bbox`, `--older-than`,
 * `--camera`, `--size`), read strictly: the whole text or nothing, so that a typo is a usage error
 * and never a default. And the one way sizes in bytes are printed.
 */

#include <tellus/cache/TileGrid.hpp>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace tellus::cli {

/** `A` or `A-B`: levels A to B with 0 <= A <= B (decimal, no sign, no spaces). */
std::optional<std::pair<int, int>> parseLevels(std::string_view text);

/** `W,S,E,N` in degrees: four finite numbers (strtod's syntax, so leading spaces pass). */
std::optional<Sector> parseBbox(const std::string& text);

/** A non-negative whole number with a unit: `45s`, `15m`, `12h` or `30d`. */
std::optional<std::chrono::milliseconds> parseDuration(std::string_view text);

/** Comma-separated finite numbers, at least minCount and at most maxCount of them. */
std::optional<std::vector<double>>
parseNumbers(const std::string& text, std::size_t minCount, std::size_t maxCount);

/** `WxH` with 1 to 16384 pixels each. */
std::optional<std::pair<int, int>> parseSize(const std::string& text);

/** "512 B", "1.5 KiB", "3.0 MiB", "2.1 GiB": one decimal from KiB on. */
std::string humanBytes(std::int64_t bytes);

} // namespace tellus::cli
