#pragma once
/**
 * @file ClusterPreview.hpp
 * @brief The master's preview window of `tellus cluster --preview [SIZE]` (issue 28,
 * docs/design/cluster-live.md): the whole dome as a domemaster (the fisheye of `tellus render
 * --dome`) of the state the master broadcasts, drawn while the channels draw theirs and shown
 * after the go, so that it holds the frame lock no longer than its own render; OUT/preview.png
 * is the last frame's.
 */

#include "ClusterArgs.hpp"
#include "FlightRenderers.hpp"
#include "PlanetTiles.hpp"

#include <tellus/cluster/FrameState.hpp>
#include <tellus/planet/Geodesy.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <expected>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace tellus::commands {

class Preview {
public:
  /** The preview's renderer (a window of c.preview x c.preview) over the master's tiles; ro as
   * every rank's (scene time, layers). A message when it cannot be made. */
  static std::expected<std::unique_ptr<Preview>, std::string>
  open(const cli::Args& a, const ClusterArgs& c, PlanetTiles& tiles, planet::RendererOptions ro);

  /** The state drawn (after it is posted: the channels draw theirs meanwhile). */
  void draw(const cluster::FrameState& s);
  /** The drawn frame shown in the window (after the go). */
  void show();
  /** The last frame drawn written as a PNG; false (said on stderr) when it cannot be. */
  bool writeLast(const std::filesystem::path& file) const;

private:
  Preview(const ClusterArgs& c, const planet::Body& body) : args_(c), geodesy_(body) {}
  const ClusterArgs& args_;
  Geodesy geodesy_;
  std::vector<BodyRenderer> bodies_;     ///< one per ClusterArgs::bodies (FlightRenderers.hpp)
  planet::Renderer* renderer_ = nullptr; ///< the one that drew last
  bool drawn_ = false;
};

} // namespace tellus::commands
