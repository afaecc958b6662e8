#pragma once
/**
 * @file LayerTimes.hpp
 * @brief Several times of one layer (issue 24): a TIME list or range (cache/TimeRange.hpp:
 * `T,T2`, `A/B/P`, `A/B`) expanded and each instant checked against the layer's declared TIME
 * dimension with the proxy's one rule (resolveTimeDimension), so that `tellus seed --time A/B/P`
 * and the renderer's `--animate LAYER=A/B/P` accept exactly the instants a WMS client's GetMap
 * may ask for, each in the layer's own spelling (one dataset per instant). The first instant the
 * layer does not declare is refused by name before anything is fetched.
 */

#include <tellus/config/Config.hpp>

#include <cstddef>
#include <expected>
#include <string>
#include <string_view>
#include <vector>

namespace tellus::cli {

/** The most instants one --time or --animate may name (a year of days, ten of months, a month of
 * hours: more is a mistake or a job for several runs). */
inline constexpr std::size_t kMaxLayerTimes = 1000;

/** The layer's instants `text` names, in order, each as the layer spells it; else why not (the
 * layer has no TIME dimension, a bad list or range, too many instants, an instant off its
 * grid). */
std::expected<std::vector<std::string>, std::string> layerTimes(
    const LayerConfig& layer, std::string_view text, std::size_t maxInstants = kMaxLayerTimes);

} // namespace tellus::cli
