#pragma once
/**
 * @file AnimateArgs.hpp
 * @brief Time that plays on the command line of `render` and `view` (issue 24):
 * `--animate LAYER=TIMES` (repeatable, one per layer; TIMES an instant list or range as
 * `seed --time` takes it: `A/B/P`, `A/B` for the layer's listed times within, `T1,T2,...`, each
 * checked against the layer's declared TIME dimension: cli::layerTimes), `--rate N` (times a
 * second, default 1), `--once` (stop on the last time; default: loop) and `--fetch-ahead K` (the
 * next K times' tiles fetched ahead, default 2). The layer must be drawn (the base or an overlay)
 * and known to the local configuration (not with --server, whose layers' times tellus cannot
 * check).
 */

#include "PlanetTiles.hpp"

#include <tellus/config/CommandLine.hpp>
#include <tellus/planet/TimeAnimation.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <cstddef>
#include <expected>
#include <string>
#include <vector>

namespace tellus::commands {

/** --animate, --rate, --once, --fetch-ahead. */
std::vector<cli::OptionSpec> animateOptions();

struct LayerAnimationArg {
  std::size_t layer = 0; ///< the renderer's index: 0 the base, then the overlays
  planet::TimeAnimation animation;
};

/** The animations the command line asks for, checked (a usage error's text otherwise): each
 * layer drawn and animated once, its times on its grid. Each animated layer starts at its first
 * time (ro's time of it set: the layer's default time is never fetched for nothing). Empty
 * without --animate; --rate, --once and --fetch-ahead without it are refused. */
std::expected<std::vector<LayerAnimationArg>, std::string>
animateArgs(const cli::Args& a, const PlanetTiles& tiles, planet::RendererOptions& ro);

} // namespace tellus::commands
