#pragma once
/**
 * @file ClusterArgs.hpp
 * @brief `tellus cluster` (issue 28, docs/design/cluster.md) split by role: the arguments every
 * rank parses alike (Cluster.cpp), the master's loop (ClusterMaster.cpp) and a channel's
 * (ClusterChannel.cpp).
 */

#include "Context.hpp"

#include <tellus/cli/Values.hpp>
#include <tellus/cluster/Comm.hpp>
#include <tellus/cluster/FrameState.hpp>
#include <tellus/planet/ChannelWarp.hpp>
#include <tellus/planet/Channels.hpp>
#include <tellus/planet/FlightPath.hpp>

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace tellus::planet {
class Renderer;
struct Body;
} // namespace tellus::planet

namespace tellus::commands {

class Console;

/** A drawn layer as the console may set it (0 the base, then the overlays). */
struct ClusterLayer {
  std::string name;
  double opacity = 1.0; ///< as configured (overlays)
  bool visible = true;
  std::vector<std::string> times; ///< its TIME values: FrameState::layerTime indexes them
};

/** The arguments every rank parses alike (mpirun gives each the same command line). */
struct ClusterArgs {
  std::vector<planet::Channel> channels;
  std::optional<planet::FlightPath> flight;
  std::string pathFile; ///< --path's
  planet::CameraPose pose;
  double fps = 25.0;
  std::filesystem::path out;
  bool waitComplete = false;
  double waitSeconds = 60.0;
  std::optional<std::array<double, 3>> background; ///< --background R,G,B in [0, 1]
  bool loop = false;     ///< --loop: the show runs until stopped (SIGINT, SIGTERM)
  bool realtime = false; ///< --realtime: the master paces the frames at --fps
  /// --channel-timeout: a channel silent this long on a frame is lost, the others go on; 0 (the
  /// default): the master waits as long as it takes (a show rendered to files wants every frame)
  double channelTimeout = 0;
  /** How long the master waits for a frame's answers: for ever without --channel-timeout. */
  double frameDeadline() const {
    return channelTimeout > 0 ? channelTimeout + (waitComplete ? waitSeconds : 0.0) : 1e9;
  }
  std::filesystem::path port; ///< --port FILE: the master's port for channels to rejoin
  std::string join;           ///< --join NAME: this process rejoins as channel NAME
  std::string control;        ///< --control HOST:PORT: the master's HTTP/JSON console
  /// --window: each channel shows its projector image (warped and blended on the GPU) in a
  /// window, swapped after the master's go
  bool window = false;
  int preview = 0; ///< --preview [SIZE]: the master's domemaster window, SIZE x SIZE; 0: none
  /// The bodies the camera may orbit (FlightRenderers.hpp's orbitableBodies: the configuration's,
  /// then each other body --path's keyframes name); FrameState::body indexes them.
  std::vector<std::string> bodies;
  /// The layers the first body's renderers draw, as configured; the console changes them.
  std::vector<ClusterLayer> layers;
};

/** Whether the channel renders another size than its projector's (CONFIG.json's "render",
 * --render-scale): the warp pass then scales, even with no warp or blend. */
inline bool scaled(const planet::Channel& ch) {
  return ch.renderedWidth() != ch.width || ch.renderedHeight() != ch.height;
}

/** The arguments checked; an empty string, else what is wrong. */
std::string parseCluster(const cli::Args& a, ClusterArgs& c);

bool appendLine(const std::filesystem::path& file, const std::string& line);

/** --window and --preview [SIZE] (ClusterPreview.cpp): "" or what is wrong (no display). */
std::string parseWindows(const cli::Args& a, ClusterArgs& c);

/** The state's scene time and layer times (those of --path's keyframes at its layerTimesAtS, or
 * the console's; a layer switches once its new time's tiles are there: Renderer::setLayerTime)
 * and the console's opacity and visibility set on r (on the layers named as c.layers). */
void applyFrameState(planet::Renderer& r, const ClusterArgs& c, const cluster::FrameState& s);

/** Frames of one state until complete (--wait-complete, up to its seconds) or one; whether the
 * last is complete. */
bool renderState(planet::Renderer& r, const planet::CameraPose& pose, const ClusterArgs& c);

/** The master's preview window (--preview, ClusterPreview.cpp): the whole dome as a domemaster
 * of the state it broadcasts. */
class Preview;

/** The master (rank 0): each frame's state to the channels, their answers, the go to swap. */
int runMaster(cluster::Comm& comm,
              const ClusterArgs& c,
              std::vector<planet::Body> bodies,
              std::optional<double> sceneTime,
              Console* console,
              Preview* preview);

/** The channel's warp mesh and blend mask (none when not configured). */
struct Calibration {
  std::optional<planet::WarpMesh> warp;
  std::optional<std::vector<float>> blend;
};

/** A channel: the master's state drawn by the renderer of the body it is over (one per
 * c.bodies), its answer, the go, then the image warped and blended (when calibrated) and
 * written. renderers empty: it could not start (the master is told). */
int runChannel(cluster::Comm& comm,
               const ClusterArgs& c,
               const planet::Channel& channel,
               const std::vector<planet::Renderer*>& renderers,
               const Calibration& cal,
               bool joined);

} // namespace tellus::commands
