#include <tellus/planet_gl/Viewer.hpp>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>

namespace tellus::planet {

namespace {

struct InputState {
  double scroll = 0.0;
};

extern "C" void onScroll(GLFWwindow* w, double, double dy) {
  if (auto* s = static_cast<InputState*>(glfwGetWindowUserPointer(w))) s->scroll += dy;
}

double wrapLon(double lon) {
  return std::remainder(lon, 360.0);
}

} // namespace

std::uint64_t runViewer(Renderer& renderer, const ViewerOptions& options) {
  auto* window = static_cast<GLFWwindow*>(renderer.nativeWindow());
  if (window == nullptr) return 0;
  InputState input;
  glfwSetWindowUserPointer(window, &input);
  glfwSetScrollCallback(window, onScroll);
  CameraPose pose = options.start;
  double lastX = 0.0, lastY = 0.0;
  bool dragging = false;
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
    if (glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS) {
      if (dragging) {
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
    // Wheel: each notch 15 % of the altitude.
    if (input.scroll != 0.0) {
      pose.altitudeM = std::clamp(pose.altitudeM * std::pow(0.85, input.scroll), 1.0, 1e9);
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
    if (glfwGetKey(window, GLFW_KEY_R) == GLFW_PRESS) pose = options.start;
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
      lastTitle = now;
      framesAtTitle = frames;
    }
  }
  glfwSetScrollCallback(window, nullptr);
  glfwSetWindowUserPointer(window, nullptr);
  return frames;
}

} // namespace tellus::planet
