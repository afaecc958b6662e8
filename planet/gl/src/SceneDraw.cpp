#include "SceneDraw.hpp"

#include "Depth.hpp"

#include <tellus/planet/Astronomy.hpp>
#include <tellus/planet/DomeDirect.hpp>
#include <tellus/planet/Ephemeris.hpp>

#include <algorithm>
#include <cmath>

namespace tellus::planet {

namespace {

/** The sun's direction in the drawn body's fixed frame at a time: the Earth's from Astronomy (as
 * before bodies), the Moon's and Mars's from their ephemeris (Ephemeris.hpp); a configured body
 * has no orbit here, so nullopt (unlit unless RendererOptions::sunLatLon places the sun). */
std::optional<glm::dvec3> sunDirectionInBodyFrame(const Body& body, double unixSeconds) {
  if (body.name == "earth") return astro::sunDirectionEcef(unixSeconds);
  if (const auto known = astro::ephemerisBodyByName(body.name))
    return astro::sunDirectionInBody(*known, unixSeconds);
  return std::nullopt;
}

} // namespace

glm::mat4 eyeCentredViewProjection(const Camera& camera) {
  glm::dmat4 view = camera.view();
  view[3] = glm::dvec4(0.0, 0.0, 0.0, 1.0);
  return glm::mat4(camera.projection() * view);
}

SceneFramebuffer::SceneFramebuffer(int width, int height)
    : fbo_(), color_(), depth_(), width_(width), height_(height) {
  glBindRenderbuffer(GL_RENDERBUFFER, color_.id());
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, width, height);
  // 32-bit float depth with reversed Z: 0.1 m to 1e9 m in one frustum (Depth.hpp).
  glBindRenderbuffer(GL_RENDERBUFFER, depth_.id());
  glRenderbufferStorage(GL_RENDERBUFFER, kDepthFormat, width, height);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_.id());
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, color_.id());
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth_.id());
}

std::vector<std::uint8_t> readFramebufferTopDown(GLuint fbo, int width, int height) {
  const auto w = static_cast<std::size_t>(width), h = static_cast<std::size_t>(height);
  std::vector<std::uint8_t> bottomUp(w * h * 4), out(w * h * 4);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, bottomUp.data());
  for (std::size_t y = 0; y < h; ++y)
    std::copy_n(bottomUp.data() + (h - 1 - y) * w * 4, w * 4, out.data() + y * w * 4);
  return out;
}

std::vector<std::uint8_t> SceneFramebuffer::readPixels() const {
  return readFramebufferTopDown(fbo_.id(), width_, height_);
}

SceneDraw::SceneDraw(const RendererOptions& options,
                     const Geodesy& geodesy,
                     const GlCapabilities& gl)
    : opt_(options), geodesy_(geodesy), gl_(gl), framebuffer_(options.width, options.height) {}

int SceneDraw::faceSize() const {
  const int side = std::min(opt_.width, opt_.height);
  return std::max(8, static_cast<int>(std::lround(opt_.dome->faceScale * side)));
}

std::expected<void, std::string> SceneDraw::openDome() {
  const auto& d = opt_.dome;
  if (!d) return {};
  if (!(d->fovDeg > 0.0 && d->fovDeg <= 220.0) || !std::isfinite(d->tiltDeg))
    return std::unexpected(std::string("the dome's field of view must be in (0, 220] degrees"));
  if (!(d->faceScale > 0.0 && d->faceScale <= 4.0))
    return std::unexpected(std::string("the dome's face scale must be in (0, 4]"));
  // The direct method makes the cube faces only when a frame falls back to them.
  auto made = Dome::create(faceSize(), gl_.glslHeader(), d->method == DomeMethod::Cube);
  if (!made) return std::unexpected(made.error());
  dome_ = std::move(*made);
  return {};
}

void SceneDraw::resize() {
  framebuffer_ = SceneFramebuffer();
  framebuffer_ = SceneFramebuffer(opt_.width, opt_.height);
  if (dome_) { // faces for the new size (kept when that fails: the old ones still draw)
    auto made = Dome::create(faceSize(),
                             gl_.glslHeader(),
                             opt_.dome->method == DomeMethod::Cube || dome_->facesAllocated());
    if (made) dome_ = std::move(*made);
  }
}

void SceneDraw::drawFrame(const Camera& camera,
                          const DrawList& list,
                          const std::vector<Node*>& drawn,
                          double groundM,
                          RenderStats& stats) {
  const DrawTarget whole{framebuffer_.id(), framebuffer_.width(), framebuffer_.height(), nullptr};
  bool direct = false;
  if (dome_ && camera.isFisheye()) {
    stats.domeErrorPx = 0.0;
    stats.domeError.clear(); // of this frame only: a later fallback may make the faces
    if (opt_.dome->method == DomeMethod::Direct) {
      stats.domeErrorPx = directChordErrorPx(camera, drawn, opt_.meshSize, groundM);
      direct = stats.domeErrorPx <= opt_.dome->directMaxErrorPx;
    }
    stats.domeMethod = direct ? "direct" : "cube";
    if (!direct) {
      const auto faces = dome_->render(
          camera,
          [&](const Camera& face, const DrawTarget& t) { drawScene(face, t, list, stats, false); },
          framebuffer_.id(),
          framebuffer_.width(),
          framebuffer_.height());
      stats.domeFaceBytes = dome_->faceBytes();
      if (faces) return;
      stats.domeError = faces.error();
      direct = opt_.dome->method == DomeMethod::Direct;
      if (direct) stats.domeMethod = "direct";
    }
  }
  if (dome_) stats.domeFaceBytes = dome_->faceBytes();
  drawScene(camera, whole, list, stats, direct);
}

void SceneDraw::drawScene(const Camera& camera,
                          const DrawTarget& target,
                          const DrawList& list,
                          RenderStats& stats,
                          bool direct) {
  glBindFramebuffer(GL_FRAMEBUFFER, target.fbo);
  glViewport(0, 0, target.width, target.height);
  beginReversedZ(gl_.clipControl);
  glClearColor(static_cast<float>(opt_.background[0]),
               static_cast<float>(opt_.background[1]),
               static_cast<float>(opt_.background[2]),
               1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  std::optional<Ecef> sun;
  if (opt_.sunLatLon) {
    sun = geodesy_.surfaceNormal((*opt_.sunLatLon)[0], (*opt_.sunLatLon)[1]);
  } else if (opt_.timeUnixSeconds) {
    if (const auto s = sunDirectionInBodyFrame(geodesy_.body(), *opt_.timeUnixSeconds))
      sun = Ecef{s->x, s->y, s->z};
  }
  const FrameContext frame{.camera = camera,
                           .target = target,
                           .body = geodesy_,
                           .drawList = list,
                           .viewProjection = eyeCentredViewProjection(camera),
                           .eye = camera.position(),
                           .sun = sun,
                           .sunlight = sun && (opt_.sunlight || opt_.sunLatLon),
                           .timeUnixSeconds = opt_.timeUnixSeconds,
                           .fisheye = direct ? dome_.get() : nullptr,
                           .framebufferWidth = framebuffer_.width(),
                           .framebufferHeight = framebuffer_.height(),
                           .stats = stats};
  for (const auto& pass : passes_)
    pass->draw(frame);
  if (direct) dome_->drawMask(framebuffer_.id(), framebuffer_.width(), framebuffer_.height());
}

} // namespace tellus::planet
