#include "ViewerAnimation.hpp"
#include "ViewerValues.hpp"

#include <tellus/planet/SceneTime.hpp>
#include <tellus/planet_gl/Viewer.hpp>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace tellus::planet {

namespace {

struct InputState {
  double scroll = 0.0;
  /** Left-button presses since the last frame, seen by the callback (polling the button's state
   * once a frame misses a click that begins and ends between two frames). */
  int presses = 0;
  std::chrono::steady_clock::time_point lastPress{};
  double pressX = 0.0, pressY = 0.0;
  bool doubleClick = false;
  double doubleX = 0.0, doubleY = 0.0;
  std::vector<int> keys; ///< keys pressed since the last frame (layer controls)
};

extern "C" void onKey(GLFWwindow* w, int key, int, int action, int) {
  if (action != GLFW_PRESS) return;
  if (auto* s = static_cast<InputState*>(glfwGetWindowUserPointer(w))) s->keys.push_back(key);
}

extern "C" void onScroll(GLFWwindow* w, double, double dy) {
  if (auto* s = static_cast<InputState*>(glfwGetWindowUserPointer(w))) s->scroll += dy;
}

extern "C" void onMouseButton(GLFWwindow* w, int button, int action, int) {
  auto* s = static_cast<InputState*>(glfwGetWindowUserPointer(w));
  if (s == nullptr || button != GLFW_MOUSE_BUTTON_LEFT || action != GLFW_PRESS) return;
  double x = 0.0, y = 0.0;
  glfwGetCursorPos(w, &x, &y);
  const auto now = std::chrono::steady_clock::now();
  if (std::chrono::duration<double>(now - s->lastPress).count() < 0.4 &&
      std::hypot(x - s->pressX, y - s->pressY) < 6.0) {
    s->doubleClick = true;
    s->doubleX = x;
    s->doubleY = y;
    s->lastPress = {};
  } else {
    s->lastPress = now;
  }
  s->pressX = x;
  s->pressY = y;
}

double wrapLon(double lon) {
  return std::remainder(lon, 360.0);
}

/** The geodetic point under a window pixel: the eye ray through the pixel's centre meets the
 * renderer's Earth model (WGS84 or the sphere, scaled to a unit sphere); nullopt when it misses. */
std::optional<std::pair<double, double>>
pick(const Geodesy& g, const Camera& cam, double px, double py, int width, int height) {
  const double a = g.equatorialRadius(), b = g.polarRadius();
  const double t = std::tan(cam.verticalFovDeg() * M_PI / 360.0);
  const double nx = (2.0 * (px + 0.5) / width - 1.0) * t * width / height;
  const double ny = (1.0 - 2.0 * (py + 0.5) / height) * t;
  glm::dvec3 dir = glm::normalize(cam.forward() + cam.right() * nx + cam.up() * ny);
  if (cam.isFisheye()) { // the dome: the pixel's angle from the centre is its radius x the scale
    const double radius = 0.5 * std::min(width, height);
    const double x = (px + 0.5 - 0.5 * width) / radius, y = (0.5 * height - py - 0.5) / radius;
    const double r = std::hypot(x, y);
    if (r > 1.0) return std::nullopt;
    const double theta = r * cam.fisheyeHalfAngleRad();
    dir = std::cos(theta) * cam.forward();
    if (r > 0.0) dir += std::sin(theta) / r * (x * cam.right() + y * cam.up());
  }
  const glm::dvec3 scale{1.0 / a, 1.0 / a, 1.0 / b};
  const glm::dvec3 o = cam.position() * scale, d = dir * scale;
  const double qa = glm::dot(d, d), qb = 2.0 * glm::dot(o, d), qc = glm::dot(o, o) - 1.0;
  const double disc = qb * qb - 4.0 * qa * qc;
  if (disc < 0.0) return std::nullopt;
  const double hit = (-qb - std::sqrt(disc)) / (2.0 * qa);
  if (!(hit > 0.0)) return std::nullopt;
  const glm::dvec3 p = cam.position() + dir * hit; // scale * (position + hit dir) = o + hit d
  const double e2 = 1.0 - (b * b) / (a * a);
  const double lat = std::atan2(p.z, (1.0 - e2) * std::hypot(p.x, p.y)) * 180.0 / M_PI;
  const double lon = std::atan2(p.y, p.x) * 180.0 / M_PI;
  if (!std::isfinite(lat) || !std::isfinite(lon)) return std::nullopt;
  return std::pair{lat, lon};
}

/** A flight from one pose to another: latitude, tilt and heading linearly (the heading and the
 * longitude the short way round), the altitude geometrically, eased in and out. */
struct Flight {
  CameraPose from, to;
  double seconds = 0.0, elapsed = 0.0;
  bool active = false;
  CameraPose at(double dt) {
    elapsed = std::min(seconds, elapsed + dt);
    const double u = elapsed / seconds;
    const double s = u * u * (3.0 - 2.0 * u);
    CameraPose p;
    p.latDeg = from.latDeg + (to.latDeg - from.latDeg) * s;
    p.lonDeg = wrapLon(from.lonDeg + std::remainder(to.lonDeg - from.lonDeg, 360.0) * s);
    p.altitudeM = from.altitudeM * std::pow(to.altitudeM / from.altitudeM, s);
    p.headingDeg = from.headingDeg + std::remainder(to.headingDeg - from.headingDeg, 360.0) * s;
    p.tiltDeg = from.tiltDeg + (to.tiltDeg - from.tiltDeg) * s;
    if (elapsed >= seconds) active = false;
    return p;
  }
};

/** The loop of runViewer: its state between frames, one method per kind of input. */
class ViewerLoop {
public:
  ViewerLoop(Renderer& renderer, GLFWwindow* window, const ViewerOptions& options);
  ~ViewerLoop();
  ViewerLoop(const ViewerLoop&) = delete;
  ViewerLoop& operator=(const ViewerLoop&) = delete;
  std::uint64_t run();

private:
  using Clock = std::chrono::steady_clock;
  void flyToDoubleClick();
  void drag(double x, double y, bool pressed);
  void zoom();
  void turn(double dt);
  bool layerKey(int key);
  bool timeKey(int key);
  double wallSeconds() const;
  void printSelectedLayer() const;
  void screenshot();
  void updateTitle(Clock::time_point now);

  Renderer& renderer_;
  GLFWwindow* window_;
  const ViewerOptions& options_;
  InputState input_;
  CameraPose pose_;
  std::vector<std::vector<std::string>> layerTimes_; ///< follows the layers when reordered
  std::size_t selected_ = 0;                         ///< the layer [ ] - = act on
  std::vector<std::size_t> timeIndex_;
  double lastX_ = 0.0, lastY_ = 0.0;
  std::pair<double, double> cursor_{0.0, 0.0}; ///< window coordinates
  bool dragging_ = false;
  Flight flight_;
  int screenshots_ = 0;
  std::uint64_t frames_ = 0;
  Clock::time_point lastTitle_ = Clock::now();
  Clock::time_point lastFrame_ = lastTitle_;
  std::uint64_t framesAtTitle_ = 0;
  CameraPose drawn_;
  int drawnW_ = 0, drawnH_ = 0;
  Clock::time_point drawnAt_ = lastTitle_;
  const tellus::Clock& clock_;
  std::optional<SceneClock> sceneClock_; ///< the scene's time, when the viewer has one
};

ViewerLoop::ViewerLoop(Renderer& renderer, GLFWwindow* window, const ViewerOptions& options)
    : renderer_(renderer), window_(window), options_(options), pose_(options.start),
      layerTimes_(options.layerTimes), selected_(renderer.layerCount() > 1 ? 1 : 0),
      timeIndex_(renderer.layerCount(), 0), drawn_(pose_),
      clock_(options.clock ? *options.clock : tellus::Clock::system()) {
  if (options.sceneTime) {
    sceneClock_.emplace(*options.sceneTime, wallSeconds());
    renderer_.setTime(*options.sceneTime);
  }
  glfwSetWindowUserPointer(window_, &input_);
  glfwSetScrollCallback(window_, onScroll);
  glfwSetMouseButtonCallback(window_, onMouseButton);
  glfwSetKeyCallback(window_, onKey);
  for (std::size_t i = 0; i < renderer_.layerCount() && i < layerTimes_.size(); ++i) {
    const auto& times = layerTimes_[i];
    const auto& now = renderer_.stats().layers.size() > i ? renderer_.stats().layers[i].time : "";
    const auto it = std::find(times.begin(), times.end(), now);
    timeIndex_[i] = it == times.end() ? 0 : static_cast<std::size_t>(it - times.begin());
  }
}

ViewerLoop::~ViewerLoop() {
  glfwSetScrollCallback(window_, nullptr);
  glfwSetMouseButtonCallback(window_, nullptr);
  glfwSetKeyCallback(window_, nullptr);
  glfwSetWindowUserPointer(window_, nullptr);
}

// Double-click: fly to the point under the cursor, three times closer.
void ViewerLoop::flyToDoubleClick() {
  input_.doubleClick = false;
  int ww = 0, wh = 0;
  glfwGetWindowSize(window_, &ww, &wh);
  // Window coordinates to framebuffer pixels (they differ on high-DPI screens).
  const double sx = ww > 0 ? static_cast<double>(renderer_.width()) / ww : 1.0;
  const double sy = wh > 0 ? static_cast<double>(renderer_.height()) / wh : 1.0;
  const auto target = pick(renderer_.geodesy(),
                           renderer_.camera(pose_),
                           input_.doubleX * sx,
                           input_.doubleY * sy,
                           renderer_.width(),
                           renderer_.height());
  if (!target) return;
  flight_ = Flight{pose_, pose_, 1.5, 0.0, true};
  flight_.to.latDeg = target->first;
  flight_.to.lonDeg = target->second;
  flight_.to.altitudeM = std::max(10.0, pose_.altitudeM / 3.0);
  std::printf("fly to %.5f, %.5f, %.0f m\n", target->first, target->second, flight_.to.altitudeM);
  std::fflush(stdout);
}

// Drag: the ground moves with the cursor (degrees per pixel from the altitude and the field of
// view; heading-aware).
void ViewerLoop::drag(double x, double y, bool pressed) {
  if (pressed) {
    if (dragging_) {
      if (x != lastX_ || y != lastY_) flight_.active = false; // the user takes over
      const double metresPerPixel = std::max(1.0, pose_.altitudeM) * 2.0 *
                                    std::tan(45.0 * M_PI / 360.0) / std::max(1, renderer_.height());
      const double degPerPixel =
          metresPerPixel / renderer_.geodesy().equatorialRadius() * 180.0 / M_PI;
      const double h = pose_.headingDeg * M_PI / 180.0;
      const double dx = x - lastX_, dy = y - lastY_;
      // Screen right is east turned by the heading; screen down is south turned likewise.
      const double north = (dy * std::cos(h) + dx * std::sin(h)) * degPerPixel;
      const double east = (-dx * std::cos(h) + dy * std::sin(h)) * degPerPixel;
      pose_.latDeg = std::clamp(pose_.latDeg + north, -90.0, 90.0);
      const double c = std::max(0.01, std::cos(pose_.latDeg * M_PI / 180.0));
      pose_.lonDeg = wrapLon(pose_.lonDeg + east / c);
    }
    dragging_ = true;
  } else {
    dragging_ = false;
  }
  lastX_ = x;
  lastY_ = y;
}

// Wheel: each notch 15 % of the height above the terrain under the camera.
void ViewerLoop::zoom() {
  if (input_.scroll == 0.0) return;
  const double ground = renderer_.terrainHeight(pose_.latDeg, pose_.lonDeg);
  const double above = std::max(1.0, pose_.altitudeM - ground);
  pose_.altitudeM = ground + std::clamp(above * std::pow(0.85, input_.scroll), 1.0, 1e9);
  input_.scroll = 0.0;
}

// W/S tilt, A/D heading at 60 degrees a second; R back to the start.
void ViewerLoop::turn(double dt) {
  const double turn = 60.0 * dt;
  if (glfwGetKey(window_, GLFW_KEY_W) == GLFW_PRESS)
    pose_.tiltDeg = std::min(90.0, pose_.tiltDeg + turn);
  if (glfwGetKey(window_, GLFW_KEY_S) == GLFW_PRESS)
    pose_.tiltDeg = std::max(0.0, pose_.tiltDeg - turn);
  if (glfwGetKey(window_, GLFW_KEY_A) == GLFW_PRESS) pose_.headingDeg -= turn;
  if (glfwGetKey(window_, GLFW_KEY_D) == GLFW_PRESS) pose_.headingDeg += turn;
  pose_.headingDeg = std::remainder(pose_.headingDeg, 360.0);
  if (glfwGetKey(window_, GLFW_KEY_R) == GLFW_PRESS) {
    pose_ = options_.start;
    flight_.active = false;
  }
}

// Layers: 0-9 select a layer (a digit of an overlay also shows or hides it), - and = lower and
// raise the selected overlay's opacity, , and . move it, ; and ' its deepest level, [ and ] step
// its time through the configured values. Whether the key changed a layer.
bool ViewerLoop::layerKey(int key) {
  const std::size_t n = renderer_.layerCount();
  if (renderer_.stats().layers.size() != n) return false; // before the first frame
  if (key >= GLFW_KEY_0 && key <= GLFW_KEY_9) {
    const auto k = static_cast<std::size_t>(key - GLFW_KEY_0);
    if (k >= n) return false;
    selected_ = k;
    if (k > 0) renderer_.setLayerVisible(k, !renderer_.stats().layers[k].visible);
  } else if ((key == GLFW_KEY_MINUS || key == GLFW_KEY_EQUAL) && selected_ > 0) {
    const double o = renderer_.stats().layers[selected_].opacity;
    renderer_.setLayerOpacity(selected_,
                              std::clamp(o + (key == GLFW_KEY_EQUAL ? 0.1 : -0.1), 0.0, 1.0));
  } else if ((key == GLFW_KEY_COMMA || key == GLFW_KEY_PERIOD) && selected_ > 0) {
    const std::size_t to = key == GLFW_KEY_COMMA ? std::max<std::size_t>(1, selected_ - 1)
                                                 : std::min(n - 1, selected_ + 1);
    if (to == selected_) return false;
    renderer_.moveLayer(selected_, to);
    if (selected_ < layerTimes_.size() && to < layerTimes_.size()) {
      std::swap(layerTimes_[selected_], layerTimes_[to]);
      std::swap(timeIndex_[selected_], timeIndex_[to]);
    }
    selected_ = to;
  } else if (key == GLFW_KEY_SEMICOLON || key == GLFW_KEY_APOSTROPHE) {
    const int levels = renderer_.stats().layers[selected_].levels;
    const int deepest = key == GLFW_KEY_SEMICOLON ? std::max(0, levels - 2) : levels;
    renderer_.setLayerMaxLevel(selected_, deepest);
  } else if (key == GLFW_KEY_LEFT_BRACKET || key == GLFW_KEY_RIGHT_BRACKET) {
    if (selected_ >= layerTimes_.size() || layerTimes_[selected_].empty()) return false;
    const auto& times = layerTimes_[selected_];
    std::size_t& t = timeIndex_[selected_];
    t = key == GLFW_KEY_RIGHT_BRACKET ? (t + 1) % times.size()
                                      : (t + times.size() - 1) % times.size();
    renderer_.setLayerTime(selected_, times[t]);
  } else {
    return false;
  }
  return true;
}

void ViewerLoop::printSelectedLayer() const {
  const auto& l = renderer_.stats().layers[selected_];
  std::printf("layer %zu %s: %s, opacity %.1f, levels %d%s, time %s%s%s\n",
              selected_,
              l.name.c_str(),
              l.visible ? "shown" : "hidden",
              l.opacity,
              l.levels,
              l.maxLevel >= 0 ? (" (max " + std::to_string(l.maxLevel) + ")").c_str() : "",
              l.time.empty() ? "(default)" : l.time.c_str(),
              l.pendingTime.empty() ? "" : " -> ",
              l.pendingTime.c_str());
  std::fflush(stdout);
}

void ViewerLoop::screenshot() {
  const auto file = options_.screenshotDir / ("tellus-" + std::to_string(++screenshots_) + ".png");
  std::string err;
  if (writePngRgb(file, renderer_.width(), renderer_.height(), renderer_.readPixels(), &err))
    std::printf("screenshot %s\n", file.c_str());
  else
    std::fprintf(stderr, "screenshot: %s\n", err.c_str());
}

double ViewerLoop::wallSeconds() const {
  return std::chrono::duration<double>(clock_.steady().time_since_epoch()).count();
}

// L faster, H slower, J backwards/forwards, K pause, N now at real time (Viewer.hpp). Whether the
// key was one of them.
bool ViewerLoop::timeKey(int key) {
  if (!sceneClock_) return false;
  SceneClock& c = *sceneClock_;
  c.advance(wallSeconds()); // the pace changes from now on
  if (key == GLFW_KEY_L) {
    c.faster();
  } else if (key == GLFW_KEY_H) {
    c.slower();
  } else if (key == GLFW_KEY_J) {
    c.reverse();
  } else if (key == GLFW_KEY_K) {
    c.togglePause();
  } else if (key == GLFW_KEY_N) {
    c = SceneClock(static_cast<double>(clock_.now()) / 1000.0, wallSeconds());
  } else {
    return false;
  }
  std::printf("time %s, x%g%s\n",
              formatSceneTime(c.time()).c_str(),
              c.paused() ? 0.0 : c.rate(),
              c.paused() ? " (paused)" : "");
  std::fflush(stdout);
  return true;
}

// The statistics line, twice a second: the window's title and the line drawn over the globe.
void ViewerLoop::updateTitle(Clock::time_point now) {
  const double sinceTitle = std::chrono::duration<double>(now - lastTitle_).count();
  if (sinceTitle < 0.5) return;
  const auto& s = renderer_.stats();
  char title[512];
  std::snprintf(title,
                sizeof title,
                "tellus  %.0f fps  %zu nodes  level %d  %zu tiles in flight  %.0f MB  "
                "%.4f, %.4f  %.0f m  heading %.0f  tilt %.0f",
                static_cast<double>(frames_ - framesAtTitle_) / sinceTitle,
                s.nodesDrawn,
                s.maxLevel,
                s.tilesInFlight,
                static_cast<double>(s.textureBytes) / (1 << 20),
                pose_.latDeg,
                pose_.lonDeg,
                pose_.altitudeM,
                pose_.headingDeg,
                pose_.tiltDeg);
  if (sceneClock_) {
    const std::string t = formatSceneTime(sceneClock_->time());
    const std::size_t used = std::strlen(title);
    std::snprintf(title + used, sizeof title - used, "  %s x%g", t.c_str(), sceneClock_->rate());
  }
  if (const std::string playing = animationStatus(renderer_); !playing.empty()) {
    const std::size_t used = std::strlen(title); // time that plays (issue 24)
    std::snprintf(title + used, sizeof title - used, "%s", playing.c_str());
  }
  int ww = 0, wh = 0; // the value under the cursor (issue 24), window to framebuffer pixels
  glfwGetWindowSize(window_, &ww, &wh);
  const std::string value = valueUnderCursor(
      renderer_,
      selected_,
      cursor_.first * (ww > 0 ? static_cast<double>(renderer_.width()) / ww : 1.0),
      cursor_.second * (wh > 0 ? static_cast<double>(renderer_.height()) / wh : 1.0));
  if (!value.empty()) {
    const std::size_t used = std::strlen(title);
    std::snprintf(title + used, sizeof title - used, "  %s", value.c_str());
  }
  glfwSetWindowTitle(window_, title);
  renderer_.setOverlayText(title + 7); // the same line on screen, without "tellus  "
  lastTitle_ = now;
  framesAtTitle_ = frames_;
}

std::uint64_t ViewerLoop::run() {
  while (!renderer_.windowShouldClose() &&
         (options_.maxFrames == 0 || frames_ < options_.maxFrames)) {
    const auto now = Clock::now();
    const double dt = std::min(0.1, std::chrono::duration<double>(now - lastFrame_).count());
    lastFrame_ = now;
    int fw = 0, fh = 0;
    glfwGetFramebufferSize(window_, &fw, &fh);
    renderer_.resize(fw, fh);
    double x = 0.0, y = 0.0;
    glfwGetCursorPos(window_, &x, &y);
    cursor_ = {x, y};
    const bool pressed = glfwGetMouseButton(window_, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS;
    if (input_.doubleClick) flyToDoubleClick();
    drag(x, y, pressed);
    zoom();
    turn(dt);
    if (flight_.active) pose_ = flight_.at(dt);
    // Keys are taken as pressed, not polled: a tap shorter than a slow frame still counts; keys
    // pressed before the first frame wait for it (the layers are known from then on).
    bool layersChanged = false;
    bool shot = false;
    std::string nextBody;
    if (frames_ > 0) {
      for (const int key : input_.keys) {
        if (key == GLFW_KEY_P)
          shot = true;
        else if (key == GLFW_KEY_ESCAPE)
          glfwSetWindowShouldClose(window_, GLFW_TRUE);
        else if (key == GLFW_KEY_B && options_.bodies.size() > 1 && options_.end != nullptr)
          nextBody = options_.bodies[1];
        else if (!timeKey(key))
          layersChanged = valueKey(renderer_, selected_, key) ||
                          animationKey(renderer_, selected_, key) || layerKey(key) || layersChanged;
      }
      input_.keys.clear();
    }
    if (!nextBody.empty()) { // B: the caller orbits the next body from here
      *options_.end = {
          nextBody, pose_, sceneClock_ ? std::optional(sceneClock_->time()) : std::nullopt};
      return frames_;
    }
    // The scene's time with the wall clock; at more than 10x real time the sun moves visibly:
    // every frame is drawn, not twice a second.
    const bool timeRuns =
        (sceneClock_ && std::abs(sceneClock_->rate()) > 1.0) || animationRuns(renderer_);
    if (sceneClock_) renderer_.setTime(sceneClock_->advance(wallSeconds()));
    if (layersChanged) {
      renderer_.frame(pose_); // the stats printed show the change
      printSelectedLayer();
    }

    // Idle (nothing moved, nothing streaming): wait for input instead of drawing the same frame
    // again, but draw twice a second so that retries and deferred splits still happen. An
    // offline viewer left alone costs almost no CPU.
    const bool moved = pose_.latDeg != drawn_.latDeg || pose_.lonDeg != drawn_.lonDeg ||
                       pose_.altitudeM != drawn_.altitudeM ||
                       pose_.headingDeg != drawn_.headingDeg || pose_.tiltDeg != drawn_.tiltDeg ||
                       fw != drawnW_ || fh != drawnH_ || timeRuns;
    const double sinceDrawn = std::chrono::duration<double>(Clock::now() - drawnAt_).count();
    if (frames_ > 0 && !moved && !renderer_.busy() && sinceDrawn < 0.5 && !shot) {
      glfwWaitEventsTimeout(0.5 - sinceDrawn);
      continue;
    }
    renderer_.frame(pose_);
    ++frames_;
    pose_ = renderer_.drawnPose(); // raised above the terrain when it went below (thesis 4.5.3)
    drawn_ = pose_;
    drawnW_ = fw;
    drawnH_ = fh;
    drawnAt_ = Clock::now();
    if (shot) screenshot();
    updateTitle(now);
  }
  return frames_;
}

} // namespace

std::uint64_t runViewer(Renderer& renderer, const ViewerOptions& options) {
  auto* window = static_cast<GLFWwindow*>(renderer.nativeWindow());
  if (window == nullptr) return 0;
  ViewerLoop loop(renderer, window, options);
  return loop.run();
}

} // namespace tellus::planet
