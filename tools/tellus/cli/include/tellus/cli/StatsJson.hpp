#pragma once
/**
 * @file StatsJson.hpp
 * @brief What `tellus cache stats --json` prints: the cache's root, its tiles and bytes, and per
 * dataset its identity, totals and levels.
 *
 * One line of compact JSON (a newline at the end), members in a fixed order:
 * `{"root":..,"tiles":N,"bytes":N,"datasets":[{"id":N,"server":..,"name":..,"folder":..,
 * "format":..,"time":..,"pinned":B,"tiles":N,"bytes":N,"levels":[{"level":N,"tiles":N,
 * "absent":N,"bytes":N},..]},..]}`. Totals are the sums over the datasets. Strings are JSON strings
 * (escaped; bytes that are not UTF-8, possible in a path, replaced by U+FFFD).
 */

#include <tellus/cache/CacheTypes.hpp>

#include <span>
#include <string>

namespace tellus::cli {

std::string cacheStatsJson(const std::string& root, std::span<const DatasetStats> datasets);

} // namespace tellus::cli
