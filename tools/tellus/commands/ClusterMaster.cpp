// `tellus cluster`'s master (rank 0; docs/design/cluster.md): it owns the camera, the scene's
// time and the flight, posts each frame's state to every channel it has, collects their answers
// until --channel-timeout (a channel that did not answer is lost: said on stderr, the others go
// on), then tells them to swap. With --port, a restarted channel rejoins with the current frame.

#include "ClusterArgs.hpp"
#include "ClusterControl.hpp"
#include "ClusterPreview.hpp"

#include <tellus/cluster/Comm.hpp>
#include <tellus/planet/OrbitChoice.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <thread>

namespace fs = std::filesystem;

namespace tellus::commands {
namespace {

volatile std::sig_atomic_t gStop = 0;
extern "C" void onStopSignal(int) {
  gStop = 1;
}

enum class ChannelState { Alive, Lost, Rejoined };

struct ChannelStatus {
  std::string name;
  int peer = 0;
  ChannelState state = ChannelState::Alive;
  std::int64_t lastFrame = -1;
};

bool lostRank = false; ///< a rank of this job died (not only a channel joined through the port)

void lose(cluster::Comm& comm, ChannelStatus& ch, std::int64_t frame, const char* why) {
  lostRank = lostRank || ch.state == ChannelState::Alive;
  std::fprintf(stderr,
               "tellus cluster: channel %s lost at frame %lld (%s); the others go on\n",
               ch.name.c_str(),
               static_cast<long long>(frame),
               why);
  comm.forget(ch.peer);
  ch.state = ChannelState::Lost;
}

/** Channels waiting at the port join: the one of their name, when it is lost. */
void acceptJoins(cluster::Comm& comm, std::vector<ChannelStatus>& channels, std::int64_t frame) {
  while (auto joined = comm.acceptJoin()) {
    auto it = std::find_if(channels.begin(), channels.end(), [&](const ChannelStatus& ch) {
      return ch.name == joined->second;
    });
    if (it == channels.end() || it->state != ChannelState::Lost) {
      std::fprintf(stderr,
                   "tellus cluster: channel %s refused: %s\n",
                   joined->second.c_str(),
                   it == channels.end() ? "no such channel" : "it is running");
      cluster::FrameState end;
      end.frame = -1;
      comm.post(joined->first, end);
      comm.forget(joined->first);
      continue;
    }
    it->peer = joined->first;
    it->state = ChannelState::Rejoined;
    std::fprintf(stderr,
                 "tellus cluster: channel %s rejoined at frame %lld\n",
                 it->name.c_str(),
                 static_cast<long long>(frame));
  }
}

bool live(const ChannelStatus& ch) {
  return ch.state != ChannelState::Lost;
}

/** What the master plays: the flight (--path, or one the console plays) at a frame of it,
 * playing or paused, or the camera (--camera, or the console's); the scene's time. */
struct Show {
  std::optional<planet::FlightPath> flight;
  std::string file;
  std::int64_t pathFrame = 0; ///< the flight's frame at --fps
  bool playing = false;
  bool cameraMode = true; ///< the camera, not the flight, gives the pose
  planet::CameraPose camera;
  std::optional<double> sceneTime;
  double fps = 25.0;
  /// The flight is --path's, which every rank read: its keyframes' layer times apply (a flight
  /// the console loads has none: ClusterControl.cpp refuses them).
  bool ranksHaveFlight = false;
  std::optional<double> layerTimesAtS; ///< where along --path the layer times were last taken
  /// The layers as the console set them (from ClusterArgs::layers): opacity, visibility, and the
  /// time's index in the layer's TIME values (-1: not set).
  struct LayerState {
    double opacity = 1.0;
    bool visible = true;
    int time = -1;
  };
  std::vector<LayerState> layers;
  const std::vector<ClusterLayer>* layerList = nullptr;

  std::int64_t count() const { return flight ? flight->frameCount(fps) : 1; }

  /** Frame n's state; the body orbited chosen by `orbit` along the flight (the console's camera
   * is over the body orbited when it took over). */
  cluster::FrameState state(std::int64_t n, planet::OrbitSwitcher& orbit) {
    cluster::FrameState s;
    s.frame = n;
    if (flight && !cameraMode) {
      const double at = flight->frameTimeS(pathFrame, fps);
      camera = orbit.flightPose(*flight, at);
      if (const auto t = flight->sceneTimeAt(at)) sceneTime = t;
      if (ranksHaveFlight) layerTimesAtS = at;
    }
    s.setPose(camera);
    s.hasSceneTime = sceneTime ? 1 : 0;
    s.sceneTimeUnixS = sceneTime.value_or(0.0);
    s.hasLayerTimes = layerTimesAtS ? 1 : 0;
    s.layerTimesAtS = layerTimesAtS.value_or(0.0);
    s.body = static_cast<std::int32_t>(orbit.current());
    for (std::size_t i = 0; i < layers.size() && i < std::size_t{cluster::kFrameLayers}; ++i) {
      s.layerOpacity[i] = static_cast<float>(layers[i].opacity);
      s.layerVisible[i] = layers[i].visible ? 1 : 0;
      s.layerTime[i] = layers[i].time;
    }
    return s;
  }

  /** After a frame: the flight's next one; false when the show is over (its end, no --loop and
   * no console to play another). */
  bool advance(bool loop, bool console) {
    if (!flight || cameraMode || !playing) return cameraMode ? loop || console : true;
    if (++pathFrame < count()) return true;
    if (loop) {
      pathFrame = 0;
      return true;
    }
    pathFrame = count() - 1;
    playing = false; // at its end, for the console to play again
    return console;
  }

  void apply(ConsoleCommand& command) {
    if (const auto* cam = std::get_if<cluster::CameraCommand>(&command.request)) {
      camera = cluster::applyCamera(*cam, camera);
      cameraMode = true;
      playing = false;
    } else if (const auto* l = std::get_if<cluster::LayerCommand>(&command.request)) {
      LayerState& layer = layers.at(static_cast<std::size_t>(command.layer)); // the console's
      layer.opacity = l->opacity.value_or(layer.opacity);
      layer.visible = l->visible.value_or(layer.visible);
      if (command.time >= 0) layer.time = command.time;
    } else if (const auto* t = std::get_if<cluster::TimeCommand>(&command.request)) {
      sceneTime = t->unixS;
    } else if (const auto* p = std::get_if<cluster::PathCommand>(&command.request)) {
      using A = cluster::PathCommand::Action;
      if (command.flight) {
        flight = std::move(command.flight);
        file = p->file;
        pathFrame = 0;
        ranksHaveFlight = false; // the layer times stay as they were
      }
      if (!flight) return; // nothing to play
      cameraMode = false;
      if (p->action == A::Play) playing = true;
      if (p->action == A::Pause) playing = false;
      if (p->action == A::Seek)
        pathFrame = std::clamp<std::int64_t>(std::llround(p->seconds * fps), 0, count() - 1);
    }
  }

  cluster::StatusReport report(std::int64_t n) const {
    cluster::StatusReport r;
    r.frame = n;
    r.camera = camera;
    r.timeUnixS = sceneTime;
    r.path = file;
    r.playing = playing && !cameraMode;
    r.pathSeconds = flight ? flight->frameTimeS(pathFrame, fps) - flight->startS() : 0.0;
    for (std::size_t i = 0; i < layers.size(); ++i) {
      const ClusterLayer& l = (*layerList)[i];
      const int t = layers[i].time;
      r.layers.push_back({l.name,
                          layers[i].opacity,
                          layers[i].visible,
                          t >= 0 ? l.times[static_cast<std::size_t>(t)] : std::string()});
    }
    return r;
  }
};

const char* stateName(ChannelState s) {
  return s == ChannelState::Alive ? "alive" : s == ChannelState::Lost ? "lost" : "rejoined";
}

/** Frame -1 to every channel; when a rank of the job died, none finalizes MPI (ranksLost). */
void endShow(cluster::Comm& comm, const std::vector<ChannelStatus>& channels, bool ranksLost) {
  cluster::FrameState end;
  end.frame = -1;
  end.ranksLost = ranksLost ? 1 : 0;
  for (const ChannelStatus& ch : channels)
    if (live(ch)) comm.post(ch.peer, end);
  if (ranksLost) comm.skipFinalize();
}

} // namespace

int runMaster(cluster::Comm& comm,
              const ClusterArgs& c,
              std::vector<planet::Body> bodies,
              std::optional<double> sceneTime,
              Console* console,
              Preview* preview) {
  const fs::path digests = c.out / "digest-master.txt";
  fs::remove(digests);
  std::vector<ChannelStatus> channels;
  std::vector<int> peers;
  for (std::size_t i = 0; i < c.channels.size(); ++i) {
    channels.push_back({c.channels[i].name, static_cast<int>(i) + 1});
    peers.push_back(static_cast<int>(i) + 1);
  }
  if (!c.port.empty())
    if (const auto opened = comm.openPort(c.port); !opened) {
      std::fprintf(stderr, "tellus cluster: %s\n", opened.error().c_str());
      endShow(comm, channels, false);
      return kExitError;
    }
  // Every channel says whether it could start (a renderer, its calibration).
  const std::vector<int> started = comm.collect(peers, 120.0 + c.frameDeadline());
  bool failed = false;
  for (std::size_t i = 0; i < channels.size(); ++i) {
    if (started[i] < 0) lose(comm, channels[i], 0, "it did not start");
    failed = failed || started[i] == 0;
  }
  if (failed) {
    std::fprintf(stderr, "tellus cluster: a channel could not start (its message above)\n");
    endShow(comm, channels, lostRank);
    return kExitError;
  }
  std::signal(SIGINT, onStopSignal);
  std::signal(SIGTERM, onStopSignal);
  Show show;
  show.flight = c.flight;
  show.ranksHaveFlight = c.flight.has_value();
  show.file = c.pathFile;
  show.playing = c.flight.has_value();
  show.cameraMode = !c.flight;
  show.camera = c.pose;
  show.sceneTime = sceneTime;
  show.fps = c.fps;
  show.layerList = &c.layers;
  for (const ClusterLayer& l : c.layers)
    show.layers.push_back({l.opacity, l.visible, -1});
  planet::OrbitSwitcher orbit(std::move(bodies));
  const auto start = std::chrono::steady_clock::now();
  std::int64_t n = 0;
  for (bool more = true; more && gStop == 0; ++n) {
    acceptJoins(comm, channels, n);
    if (console)
      for (ConsoleCommand& command : console->take())
        show.apply(command);
    const cluster::FrameState s = show.state(n, orbit);
    std::vector<std::size_t> asked;
    peers.clear();
    for (std::size_t i = 0; i < channels.size(); ++i)
      if (live(channels[i])) {
        comm.post(channels[i].peer, s);
        asked.push_back(i);
        peers.push_back(channels[i].peer);
      }
    bool well = appendLine(digests, cluster::digestLine(s));
    if (preview) preview->draw(s); // while the channels draw theirs
    const std::vector<int> answers = comm.collect(peers, c.frameDeadline());
    for (std::size_t k = 0; k < asked.size(); ++k) {
      if (answers[k] < 0) lose(comm, channels[asked[k]], n, "no answer in time");
      well = well && answers[k] != 0;
    }
    for (std::size_t k = 0; k < asked.size(); ++k) // the swap (or the stop)
      if (answers[k] >= 0) {
        comm.postGo(channels[asked[k]].peer, well, lostRank);
        channels[asked[k]].lastFrame = n;
      }
    if (preview && well) preview->show();
    if (!well) {
      std::fprintf(stderr,
                   "tellus cluster: frame %lld failed on a rank (its message above); stopped\n",
                   static_cast<long long>(n));
      if (lostRank) comm.skipFinalize();
      return kExitError;
    }
    if (console) { // GET /status from now on
      cluster::StatusReport report = show.report(n);
      for (const ChannelStatus& ch : channels)
        report.channels.push_back({ch.name, stateName(ch.state), ch.lastFrame});
      console->publish(cluster::statusJson(report));
    }
    more = show.advance(c.loop, console != nullptr);
    if (c.realtime) // the next frame's moment
      std::this_thread::sleep_until(
          start + std::chrono::duration_cast<std::chrono::nanoseconds>(
                      std::chrono::duration<double>(static_cast<double>(n + 1) / c.fps)));
  }
  endShow(comm, channels, lostRank);
  const bool previewWritten = !preview || preview->writeLast(c.out / "preview.png");
  std::size_t lost = 0;
  for (const ChannelStatus& ch : channels)
    lost += live(ch) ? 0u : 1u;
  std::printf("tellus cluster: %lld frames of %zu channels in %s after %.2f s%s\n",
              static_cast<long long>(n),
              c.channels.size(),
              c.out.string().c_str(),
              std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
              lost > 0 ? "; channels lost (above)" : "");
  return lost > 0 || !previewWritten ? kExitError : kExitOk;
}

} // namespace tellus::commands
