// `tellus cluster --window` and `--preview [SIZE]` (issue 28, docs/design/cluster-live.md): the
// options, and the master's preview window (ClusterPreview.hpp).

#include "ClusterPreview.hpp"

#include "Bodies.hpp"
#include "FlightRenderers.hpp"
#include "GlobeArgs.hpp"

#include <cstdio>
#include <cstdlib>

namespace fs = std::filesystem;

namespace tellus::commands {

std::string parseWindows(const cli::Args& a, ClusterArgs& c) {
  c.window = a.flag("window");
  if (a.flag("preview")) {
    c.preview = 512;
    if (const auto p = a.get("preview"); p && !p->empty()) {
      const auto v = cli::parseNumbers(*p, 1, 1);
      if (!v || (*v)[0] < 16.0 || (*v)[0] > 16384.0 || (*v)[0] != static_cast<int>((*v)[0]))
        return "--preview=SIZE must be a whole number of pixels in [16, 16384]: " + *p;
      c.preview = static_cast<int>((*v)[0]);
    }
  }
  if (!c.window && c.preview == 0) return {};
  const char* x = std::getenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  if ((x == nullptr || *x == '\0') && (wayland == nullptr || *wayland == '\0'))
    return std::string(c.window ? "--window" : "--preview") +
           " opens a window and there is no display (DISPLAY is not set): run it on the dome's X "
           "server, or under xvfb-run";
  return {};
}

std::expected<std::unique_ptr<Preview>, std::string> Preview::open(const cli::Args& a,
                                                                   const ClusterArgs& c,
                                                                   PlanetTiles& tiles,
                                                                   planet::RendererOptions ro) {
  std::unique_ptr<Preview> p(new Preview(c, tiles.bodyFor(tiles.earth)));
  // The domemaster of `tellus render --dome --size N` (the configuration's dome, --dome-tilt).
  if (!ro.dome) ro.dome = planet::DomeOptions{};
  if (const auto d = domeArgs(a); d && d->tiltDeg) ro.dome->tiltDeg = *d->tiltDeg;
  ro.channelView.reset();
  ro.width = ro.height = c.preview;
  if (c.background) ro.background = *c.background;
  if (const fs::path global = dataDir(a) / "bmng_2048x1024.jpg";
      tiles.body == "earth" && fs::exists(global))
    ro.globalImage = global;
  addSceneBodies(ro, tiles.sceneBodies, dataDir(a), tiles.earth);
  ro.visibleWindow = true;
  ro.presentOnRequest = true; // after the go
  ro.vsync = false;           // its swap must not hold up the frame lock
  ro.windowTitle = "tellus cluster: the dome";
  // A renderer per body the flight orbits, as each channel has (one window between them).
  auto made = makeBodyRenderers(a, "cluster", tiles, c.bodies, p->geodesy_, ro, tiles.earth);
  if (!made) return std::unexpected("--preview: a renderer could not be made (above)");
  p->bodies_ = std::move(*made);
  p->renderer_ = p->bodies_.front().renderer.get();
  return p;
}

void Preview::draw(const cluster::FrameState& s) {
  if (s.body >= 0 && static_cast<std::size_t>(s.body) < bodies_.size())
    renderer_ = bodies_[static_cast<std::size_t>(s.body)].renderer.get();
  applyFrameState(*renderer_, args_, s);
  if (!renderState(*renderer_, s.pose(), args_) && args_.waitComplete)
    std::fprintf(stderr,
                 "tellus cluster: the preview of frame %lld not complete after %g s\n",
                 static_cast<long long>(s.frame),
                 args_.waitSeconds);
  drawn_ = true;
}

void Preview::show() {
  renderer_->present();
}

bool Preview::writeLast(const fs::path& file) const {
  if (!drawn_) return true;
  std::string err;
  if (planet::writePngRgb(
          file, renderer_->width(), renderer_->height(), renderer_->readPixels(), &err))
    return true;
  std::fprintf(stderr, "tellus cluster: %s\n", err.c_str());
  return false;
}

} // namespace tellus::commands
