#pragma once
/**
 * @file RenderLayers.hpp
 * @brief The layers `render` and `view` draw over the base (issue #7): renderer.layers[1..] of
 * the configuration and --overlay, each on the body shown (issue 26), combined with their
 * regional datasets; split from PlanetTiles.cpp.
 */

#include "PlanetTiles.hpp"

#include <tellus/config/CommandLine.hpp>
#include <tellus/config/Config.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <string>

namespace tellus::commands {

/** renderer.layers[1..] and each --overlay NAME[,OPACITY] over the base `ro.layer` on `body`
 * (config null with --server: every layer is the server's); the base's time from
 * renderer.layers[0] when it is the base; regional datasets combined over t.source (which then
 * reads them); t.layerTimes filled. With `overlayArgs` false the --overlay options are not read
 * (another body's renderer). False after saying why. */
bool applyRenderLayers(const RendererSettings& g,
                       const Config* config,
                       const cli::Args& a,
                       planet::RendererOptions& ro,
                       PlanetTiles& t,
                       const char* cmd,
                       const std::string& body,
                       bool overlayArgs = true);

} // namespace tellus::commands
