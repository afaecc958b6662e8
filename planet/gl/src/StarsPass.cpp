#include "StarsPass.hpp"

#include "Dome.hpp"
#include "GlShader.hpp"
#include "Shaders.hpp"

#include <tellus/planet/Astronomy.hpp>

#include <array>
#include <numbers>
#include <vector>

namespace tellus::planet {

namespace {

/** The point sprite's side in pixels: every pixel centre within 3.5 px (4.4 sigma) each way. */
constexpr float kSpritePx = 7.0f;

} // namespace

std::expected<std::unique_ptr<StarsPass>, std::string> StarsPass::create(
    const GlCapabilities& gl, const StarCatalogue& catalogue, const StarsPassOptions& options) {
  std::unique_ptr<StarsPass> p(new StarsPass());
  const std::string header = gl.glslHeader();
  const std::string defines = options.fisheye ? "#define TELLUS_FISHEYE 1\n" : "";
  auto program =
      linkProgram(header + defines + kShader_stars_vert, header + kShader_stars_frag, "stars");
  if (!program) return std::unexpected(program.error());
  p->program_ = std::move(*program);
  const GLuint id = p->program_.id();
  p->uCelestialToWorld_ = glGetUniformLocation(id, "uCelestialToWorld");
  p->uViewProj_ = glGetUniformLocation(id, "uViewProj");
  p->uViewport_ = glGetUniformLocation(id, "uViewport");
  p->uInvTwoSigma2_ = glGetUniformLocation(id, "uInvTwoSigma2");
  glUseProgram(id);
  glUniform1f(p->uInvTwoSigma2_, static_cast<float>(0.5 / (kStarSigmaPx * kStarSigmaPx)));
  if (const GLint f = glGetUniformLocation(id, "uFisheye"); f >= 0) glUniform1i(f, 0);
  glUseProgram(0);
  p->upload(catalogue, options);
  return p;
}

void StarsPass::upload(const StarCatalogue& catalogue, const StarsPassOptions& options) {
  // Per star: the J2000 unit vector, then the footprint's peak colour (colour x energy over the
  // Gaussian's integral 2 pi sigma^2, so the pixels sum to the energy).
  const double integral = 2.0 * std::numbers::pi * kStarSigmaPx * kStarSigmaPx;
  std::vector<float> v;
  v.reserve(catalogue.size() * 6);
  for (const Star& s : catalogue.stars()) {
    if (!(s.vmag <= options.magnitudeLimit)) continue;
    const double peak = starEnergy(s.vmag, options.brightness) / integral;
    if (!(peak > 0.0)) continue;
    const glm::dvec3 d = starCelestialDirection(s);
    const std::array<double, 3> c = starColour(s.bv);
    for (const double x : {d.x, d.y, d.z, c[0] * peak, c[1] * peak, c[2] * peak})
      v.push_back(static_cast<float>(x));
  }
  count_ = static_cast<GLsizei>(v.size() / 6);
  vao_ = GlVertexArray();
  vbo_ = GlBuffer();
  glBindVertexArray(vao_.id());
  glBindBuffer(GL_ARRAY_BUFFER, vbo_.id());
  glBufferData(GL_ARRAY_BUFFER,
               static_cast<GLsizeiptr>(v.size() * sizeof(float)),
               v.empty() ? nullptr : v.data(),
               GL_STATIC_DRAW);
  constexpr GLsizei stride = 6 * sizeof(float);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(
      1, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(3 * sizeof(float)));
  glBindVertexArray(0);
  glBindBuffer(GL_ARRAY_BUFFER, 0);
}

void StarsPass::draw(const FrameContext& frame) {
  if (count_ == 0) return;
  // The sky's rotation at the scene's time, in double, narrowed once (a rotation: no large value).
  const glm::mat3 sky(astro::celestialToEcef(frame.timeUnixSeconds.value_or(kJ2000UnixSeconds)));
  glUseProgram(program_.id());
  glUniformMatrix3fv(uCelestialToWorld_, 1, GL_FALSE, &sky[0][0]);
  glUniformMatrix4fv(uViewProj_, 1, GL_FALSE, &frame.viewProjection[0][0]);
  glUniform2f(
      uViewport_, static_cast<float>(frame.target.width), static_cast<float>(frame.target.height));
  if (frame.fisheye != nullptr)
    frame.fisheye->beginDirect(
        program_, frame.camera, frame.framebufferWidth, frame.framebufferHeight);
  glDisable(GL_DEPTH_TEST);
  glDepthMask(GL_FALSE);
  glEnable(GL_BLEND);
  glBlendFunc(GL_ONE, GL_ONE);
  glPointSize(kSpritePx);
  glBindVertexArray(vao_.id());
  glDrawArrays(GL_POINTS, 0, count_);
  glBindVertexArray(0);
  glPointSize(1.0f);
  glDisable(GL_BLEND);
  glDepthMask(GL_TRUE);
  glEnable(GL_DEPTH_TEST);
  if (frame.fisheye != nullptr) frame.fisheye->endDirect(program_);
}

} // namespace tellus::planet
