// A channel of `tellus cluster` (rank >= 1, or a restarted one joined through the master's
// port; docs/design/cluster.md): the master's state drawn, its answer, the go, then the swap:
// the image warped and blended (when calibrated; on the GPU and shown in its window with
// --window) and written.

#include "ClusterArgs.hpp"

#include <tellus/planet_gl/Renderer.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <string>
#include <thread>

namespace fs = std::filesystem;

namespace tellus::commands {
bool renderState(planet::Renderer& r, const planet::CameraPose& pose, const ClusterArgs& c) {
  const auto begin = std::chrono::steady_clock::now();
  for (;;) {
    r.frame(pose);
    if (!c.waitComplete || r.complete()) return r.complete();
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count() >
        c.waitSeconds)
      return false;
    if (!r.busy() || r.stats().uploadsPending == 0)
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

void applyFrameState(planet::Renderer& r, const ClusterArgs& c, const cluster::FrameState& s) {
  r.setTime(s.hasSceneTime ? std::optional<double>(s.sceneTimeUnixS) : std::nullopt);
  const auto& layers = r.stats().layers;
  std::map<std::size_t, std::string> wanted; // by layer: the keyframes' time, else the console's
  if (s.hasLayerTimes != 0 && c.flight)
    for (const auto& [name, time] : c.flight->layerTimesAt(s.layerTimesAtS))
      for (std::size_t i = 0; i < layers.size(); ++i)
        if (layers[i].name == name) wanted[i] = time;
  // The console's: on the layers of c.layers (the first body's renderers draw them).
  const std::size_t n =
      std::min({layers.size(), c.layers.size(), std::size_t{cluster::kFrameLayers}});
  for (std::size_t i = 0; i < n; ++i) {
    if (layers[i].name != c.layers[i].name) continue;
    const auto& times = c.layers[i].times;
    if (const int t = s.layerTime[i]; t >= 0 && static_cast<std::size_t>(t) < times.size())
      wanted[i] = times[static_cast<std::size_t>(t)];
    if (i == 0) continue; // the base has neither
    const double opacity = static_cast<double>(s.layerOpacity[i]);
    if (layers[i].opacity != opacity) r.setLayerOpacity(i, opacity);
    if (layers[i].visible != (s.layerVisible[i] != 0)) r.setLayerVisible(i, s.layerVisible[i] != 0);
  }
  for (const auto& [i, time] : wanted)
    if (layers[i].time != time && layers[i].pendingTime != time) r.setLayerTime(i, time);
}

int runChannel(cluster::Comm& comm,
               const ClusterArgs& c,
               const planet::Channel& channel,
               const std::vector<planet::Renderer*>& renderers,
               const Calibration& cal,
               bool joined) {
  const fs::path digests = c.out / ("digest-" + channel.name + ".txt");
  if (!joined) { // a channel restarted goes on with its file
    fs::remove(digests);
    comm.answer(!renderers.empty());
  }
  if (renderers.empty()) return kExitError;
  // The master waits up to --channel-timeout (and --wait-complete's) for every channel's answer;
  // silence longer than that means it is gone, or it dropped this channel.
  const double wait = 2.0 * c.frameDeadline() + 10.0 + (c.realtime ? 1.0 / c.fps : 0.0);
  for (bool first = true;; first = false) {
    const auto s = comm.receiveState(first ? std::max(300.0, wait) : wait);
    if (!s) {
      std::fprintf(stderr,
                   "tellus cluster: channel %s: no frame from the master in %g s; stopped\n",
                   channel.name.c_str(),
                   first ? std::max(300.0, wait) : wait);
      return kExitError;
    }
    if (s->frame < 0) {                                      // the end of the show
      if (s->ranksLost != 0 && !joined) comm.skipFinalize(); // a rank of its own job died
      return kExitOk;
    }
    if (s->body < 0 || static_cast<std::size_t>(s->body) >= renderers.size()) {
      std::fprintf(stderr,
                   "tellus cluster: channel %s: frame %lld is over body %d; it draws %zu\n",
                   channel.name.c_str(),
                   static_cast<long long>(s->frame),
                   static_cast<int>(s->body),
                   renderers.size());
      comm.answer(false);
      return kExitError;
    }
    planet::Renderer* renderer = renderers[static_cast<std::size_t>(s->body)];
    applyFrameState(*renderer, c, *s);
    bool well = renderState(*renderer, s->pose(), c) || !c.waitComplete;
    if (!well)
      std::fprintf(stderr,
                   "tellus cluster: channel %s: frame %lld not complete after %g s\n",
                   channel.name.c_str(),
                   static_cast<long long>(s->frame),
                   c.waitSeconds);
    well = appendLine(digests, cluster::digestLine(*s)) && well;
    comm.answer(well);
    const auto go = comm.receiveGo(wait); // the barrier before the swap
    if (!go) {
      std::fprintf(stderr,
                   "tellus cluster: channel %s: the master dropped it at frame %lld (too late?) "
                   "or is gone; stopped\n",
                   channel.name.c_str(),
                   static_cast<long long>(s->frame));
      return kExitError;
    }
    if (!*go)
      return kExitError; // the show stopped: a rank failed (its message on its stderr;
                         // a rank of the job lost: no MPI_Finalize, receiveGo)
    char name[32];
    std::snprintf(name, sizeof name, "-%05lld.png", static_cast<long long>(s->frame));
    std::string err;
    planet::ChannelImage image{renderer->width(), renderer->height(), {}};
    if (c.window) { // warped and blended on the GPU (ProjectorWarp.hpp): shown, then read
      renderer->present();
      image.rgba = renderer->readPresented();
      image.width = channel.width; // the projector's image
      image.height = channel.height;
    } else {
      image.rgba = renderer->readPixels();
    }
    if (!c.window && (cal.warp || cal.blend || scaled(channel))) // the pass (ChannelWarp.hpp)
      image = planet::warpAndBlend(image,
                                   channel.width,
                                   channel.height,
                                   cal.warp ? &*cal.warp : nullptr,
                                   cal.blend ? &*cal.blend : nullptr);
    if (!planet::writePngRgb(c.out / ("channel-" + channel.name + name),
                             image.width,
                             image.height,
                             image.rgba,
                             &err)) {
      std::fprintf(stderr, "tellus cluster: %s\n", err.c_str());
      return kExitError; // the master loses this channel at the next frame
    }
  }
}

} // namespace tellus::commands
