#include <tellus/planet_gl/Viewer.hpp>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
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

} // namespace

std::uint64_t runViewer(Renderer& renderer, const ViewerOptions& options) {
  auto* window = static_cast<GLFWwindow*>(renderer.nativeWindow());
  if (window == nullptr) return 0;
  InputState input;
  glfwSetWindowUserPointer(window, &input);
  glfwSetScrollCallback(window, onScroll);
  glfwSetMouseButtonCallback(window, onMouseButton);
  glfwSetKeyCallback(window, onKey);
  CameraPose pose = options.start;
  auto layerTimes = options.layerTimes; // follows the layers when they are reordered
  std::size_t selected = renderer.layerCount() > 1 ? 1 : 0; // the layer [ ] - = act on
  std::vector<std::size_t> timeIndex(renderer.layerCount(), 0);
  for (std::size_t i = 0; i < renderer.layerCount() && i < layerTimes.size(); ++i) {
    const auto& times = layerTimes[i];
    const auto& now = renderer.stats().layers.size() > i ? renderer.stats().layers[i].time : "";
    const auto it = std::find(times.begin(), times.end(), now);
    timeIndex[i] = it == times.end() ? 0 : static_cast<std::size_t>(it - times.begin());
  }
  double lastX = 0.0, lastY = 0.0;
  bool dragging = false;
  Flight flight;
  bool screenshotHeld = false;
  int screenshots = 0;
  std::uint64_t frames = 0;
  auto lastTitle = std::chrono::steady_clock::now();
  auto lastFrame = lastTitle;
  std::uint64_t framesAtTitle = 0;
  CameraPose drawn = pose;
  int drawnW = 0, drawnH = 0;
  auto drawnAt = lastTitle;
  constexpr double kEarthRadius = 6371000.0;
  while (!renderer.windowShouldClose() && (options.maxFrames == 0 || frames < options.maxFrames)) {
    const auto now = std::chrono::steady_clock::now();
    const double dt = std::min(0.1, std::chrono::duration<double>(now - lastFrame).count());
    lastFrame = now;
    int fw = 0, fh = 0;
    glfwGetFramebufferSize(window, &fw, &fh);
    renderer.resize(fw, fh);

    // Drag: the ground moves with the cursor (degrees per pixel from the altitude and the field
    // of view; heading-aware).
    double x = 0.0, y = 0.0;
    glfwGetCursorPos(window, &x, &y);
    const bool pressed = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS;
    // Double-click: fly to the point under the cursor, three times closer.
    if (input.doubleClick) {
      input.doubleClick = false;
      int ww = 0, wh = 0;
      glfwGetWindowSize(window, &ww, &wh);
      // Window coordinates to framebuffer pixels (they differ on high-DPI screens).
      const double sx = ww > 0 ? static_cast<double>(renderer.width()) / ww : 1.0;
      const double sy = wh > 0 ? static_cast<double>(renderer.height()) / wh : 1.0;
      if (const auto target = pick(renderer.geodesy(),
                                   renderer.camera(pose),
                                   input.doubleX * sx,
                                   input.doubleY * sy,
                                   renderer.width(),
                                   renderer.height())) {
        flight = Flight{pose, pose, 1.5, 0.0, true};
        flight.to.latDeg = target->first;
        flight.to.lonDeg = target->second;
        flight.to.altitudeM = std::max(10.0, pose.altitudeM / 3.0);
        std::printf(
            "fly to %.5f, %.5f, %.0f m\n", target->first, target->second, flight.to.altitudeM);
        std::fflush(stdout);
      }
    }
    if (pressed) {
      if (dragging) {
        if (x != lastX || y != lastY) flight.active = false; // the user takes over
        const double metresPerPixel = std::max(1.0, pose.altitudeM) * 2.0 *
                                      std::tan(45.0 * M_PI / 360.0) /
                                      std::max(1, renderer.height());
        const double degPerPixel = metresPerPixel / kEarthRadius * 180.0 / M_PI;
        const double h = pose.headingDeg * M_PI / 180.0;
        const double dx = x - lastX, dy = y - lastY;
        // Screen right is east turned by the heading; screen down is south turned likewise.
        const double north = (dy * std::cos(h) + dx * std::sin(h)) * degPerPixel;
        const double east = (-dx * std::cos(h) + dy * std::sin(h)) * degPerPixel;
        pose.latDeg = std::clamp(pose.latDeg + north, -90.0, 90.0);
        const double c = std::max(0.01, std::cos(pose.latDeg * M_PI / 180.0));
        pose.lonDeg = wrapLon(pose.lonDeg + east / c);
      }
      dragging = true;
    } else {
      dragging = false;
    }
    lastX = x;
    lastY = y;
    // Wheel: each notch 15 % of the height above the terrain under the camera.
    if (input.scroll != 0.0) {
      const double ground = renderer.terrainHeight(pose.latDeg, pose.lonDeg);
      const double above = std::max(1.0, pose.altitudeM - ground);
      pose.altitudeM = ground + std::clamp(above * std::pow(0.85, input.scroll), 1.0, 1e9);
      input.scroll = 0.0;
    }
    const double turn = 60.0 * dt;
    if (glfwGetKey(window, GLFW_KEY_W) == GLFW_PRESS)
      pose.tiltDeg = std::min(90.0, pose.tiltDeg + turn);
    if (glfwGetKey(window, GLFW_KEY_S) == GLFW_PRESS)
      pose.tiltDeg = std::max(0.0, pose.tiltDeg - turn);
    if (glfwGetKey(window, GLFW_KEY_A) == GLFW_PRESS) pose.headingDeg -= turn;
    if (glfwGetKey(window, GLFW_KEY_D) == GLFW_PRESS) pose.headingDeg += turn;
    pose.headingDeg = std::remainder(pose.headingDeg, 360.0);
    if (glfwGetKey(window, GLFW_KEY_R) == GLFW_PRESS) {
      pose = options.start;
      flight.active = false;
    }
    if (flight.active) pose = flight.at(dt);
    // Layers: 0-9 select a layer (a digit of an overlay also shows or hides it), - and = lower and
    // raise the selected overlay's opacity, [ and ] step its time through the configured values.
    bool layersChanged = false;
    for (const int key : input.keys) {
      const std::size_t n = renderer.layerCount();
      if (renderer.stats().layers.size() != n) continue; // before the first frame
      if (key >= GLFW_KEY_0 && key <= GLFW_KEY_9) {
        const auto k = static_cast<std::size_t>(key - GLFW_KEY_0);
        if (k >= n) continue;
        selected = k;
        if (k > 0) renderer.setLayerVisible(k, !renderer.stats().layers[k].visible);
      } else if ((key == GLFW_KEY_MINUS || key == GLFW_KEY_EQUAL) && selected > 0) {
        const double o = renderer.stats().layers[selected].opacity;
        renderer.setLayerOpacity(selected,
                                 std::clamp(o + (key == GLFW_KEY_EQUAL ? 0.1 : -0.1), 0.0, 1.0));
      } else if ((key == GLFW_KEY_COMMA || key == GLFW_KEY_PERIOD) && selected > 0) {
        const std::size_t to = key == GLFW_KEY_COMMA ? std::max<std::size_t>(1, selected - 1)
                                                     : std::min(n - 1, selected + 1);
        if (to == selected) continue;
        renderer.moveLayer(selected, to);
        if (selected < layerTimes.size() && to < layerTimes.size()) {
          std::swap(layerTimes[selected], layerTimes[to]);
          std::swap(timeIndex[selected], timeIndex[to]);
        }
        selected = to;
      } else if (key == GLFW_KEY_SEMICOLON || key == GLFW_KEY_APOSTROPHE) {
        const int levels = renderer.stats().layers[selected].levels;
        const int deepest = key == GLFW_KEY_SEMICOLON ? std::max(0, levels - 2) : levels;
        renderer.setLayerMaxLevel(selected, deepest);
      } else if (key == GLFW_KEY_LEFT_BRACKET || key == GLFW_KEY_RIGHT_BRACKET) {
        if (selected >= layerTimes.size() || layerTimes[selected].empty()) continue;
        const auto& times = layerTimes[selected];
        std::size_t& t = timeIndex[selected];
        t = key == GLFW_KEY_RIGHT_BRACKET ? (t + 1) % times.size()
                                          : (t + times.size() - 1) % times.size();
        renderer.setLayerTime(selected, times[t]);
      } else {
        continue;
      }
      layersChanged = true;
    }
    input.keys.clear();
    if (layersChanged) {
      renderer.frame(pose); // the stats below show the change
      const auto& l = renderer.stats().layers[selected];
      std::printf("layer %zu %s: %s, opacity %.1f, levels %d%s, time %s%s%s\n",
                  selected,
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
    if (glfwGetKey(window, GLFW_KEY_ESCAPE) == GLFW_PRESS)
      glfwSetWindowShouldClose(window, GLFW_TRUE);

    // Idle (nothing moved, nothing streaming): wait for input instead of drawing the same frame
    // again, but draw twice a second so that retries and deferred splits still happen. An
    // offline viewer left alone costs almost no CPU.
    const bool moved = pose.latDeg != drawn.latDeg || pose.lonDeg != drawn.lonDeg ||
                       pose.altitudeM != drawn.altitudeM || pose.headingDeg != drawn.headingDeg ||
                       pose.tiltDeg != drawn.tiltDeg || fw != drawnW || fh != drawnH;
    const double sinceDrawn =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - drawnAt).count();
    const bool shot = glfwGetKey(window, GLFW_KEY_P) == GLFW_PRESS;
    if (frames > 0 && !moved && !renderer.busy() && sinceDrawn < 0.5 &&
        !(shot && !screenshotHeld)) {
      glfwWaitEventsTimeout(0.5 - sinceDrawn);
      continue;
    }
    renderer.frame(pose);
    ++frames;
    pose = renderer.drawnPose(); // raised above the terrain when it went below (thesis 4.5.3)
    drawn = pose;
    drawnW = fw;
    drawnH = fh;
    drawnAt = std::chrono::steady_clock::now();

    if (shot && !screenshotHeld) {
      const auto file =
          options.screenshotDir / ("tellus-" + std::to_string(++screenshots) + ".png");
      std::string err;
      if (writePngRgb(file, renderer.width(), renderer.height(), renderer.readPixels(), &err))
        std::printf("screenshot %s\n", file.c_str());
      else
        std::fprintf(stderr, "screenshot: %s\n", err.c_str());
    }
    screenshotHeld = shot;

    const double sinceTitle = std::chrono::duration<double>(now - lastTitle).count();
    if (sinceTitle >= 0.5) {
      const auto& s = renderer.stats();
      char title[256];
      std::snprintf(title,
                    sizeof title,
                    "tellus  %.0f fps  %zu nodes  level %d  %zu tiles in flight  %.0f MB  "
                    "%.4f, %.4f  %.0f m  heading %.0f  tilt %.0f",
                    static_cast<double>(frames - framesAtTitle) / sinceTitle,
                    s.nodesDrawn,
                    s.maxLevel,
                    s.tilesInFlight,
                    static_cast<double>(s.textureBytes) / (1 << 20),
                    pose.latDeg,
                    pose.lonDeg,
                    pose.altitudeM,
                    pose.headingDeg,
                    pose.tiltDeg);
      glfwSetWindowTitle(window, title);
      renderer.setOverlayText(title + 7); // the same line on screen, without "tellus  "
      lastTitle = now;
      framesAtTitle = frames;
    }
  }
  glfwSetScrollCallback(window, nullptr);
  glfwSetMouseButtonCallback(window, nullptr);
  glfwSetKeyCallback(window, nullptr);
  glfwSetWindowUserPointer(window, nullptr);
  return frames;
}

} // namespace tellus::planet
