#include "AtmospherePass.hpp"

#include "Depth.hpp"
#include "Dome.hpp"
#include "GlShader.hpp"
#include "Shaders.hpp"

#include <glm/glm.hpp>

#include <cmath>
#include <numbers>

namespace tellus::planet {

namespace {

GlTexture makeTable2d(int w, int h, const std::vector<float>& data) {
  GlTexture t;
  glBindTexture(GL_TEXTURE_2D, t.id());
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB16F, w, h, 0, GL_RGB, GL_FLOAT, data.data());
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glBindTexture(GL_TEXTURE_2D, 0);
  return t;
}

GlTexture makeTable3d(int w, int h, int d, const std::vector<float>& data) {
  GlTexture t;
  glBindTexture(GL_TEXTURE_3D, t.id());
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexImage3D(GL_TEXTURE_3D, 0, GL_RGB16F, w, h, d, 0, GL_RGB, GL_FLOAT, data.data());
  glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_WRAP_R, GL_CLAMP_TO_EDGE);
  glBindTexture(GL_TEXTURE_3D, 0);
  return t;
}

GLint at(GLuint program, const char* name) {
  return glGetUniformLocation(program, name);
}

} // namespace

AtmospherePass::AtmospherePass(AtmosphereTables tables,
                               double exposure,
                               const Geodesy& body,
                               bool clipControl)
    : tables_(std::move(tables)), exposure_(exposure),
      polarStretch_(body.equatorialRadius() / body.polarRadius()), clipControl_(clipControl) {}

std::expected<std::unique_ptr<AtmospherePass>, std::string>
AtmospherePass::create(const GlCapabilities& gl,
                       AtmosphereParameters parameters,
                       double exposure,
                       const Geodesy& body) {
  if (parameters.bottomRadiusM <= 0.0) parameters.bottomRadiusM = body.equatorialRadius();
  if (const std::string bad = parameters.validate(); !bad.empty())
    return std::unexpected("atmosphere: " + bad);
  if (!(exposure > 0.0 && std::isfinite(exposure)))
    return std::unexpected(std::string("atmosphere: the exposure must be positive"));
  return create(gl, AtmosphereTables::precompute(parameters), exposure, body);
}

std::expected<std::unique_ptr<AtmospherePass>, std::string> AtmospherePass::create(
    const GlCapabilities& gl, AtmosphereTables tables, double exposure, const Geodesy& body) {
  if (!(exposure > 0.0 && std::isfinite(exposure)))
    return std::unexpected(std::string("atmosphere: the exposure must be positive"));
  std::unique_ptr<AtmospherePass> p(
      new AtmospherePass(std::move(tables), exposure, body, gl.clipControl));
  const std::string header = gl.glslHeader();
  auto program = linkProgram(
      header + kShader_atmosphere_vert, header + kShader_atmosphere_frag, "atmosphere shader");
  if (!program) return std::unexpected(program.error());
  p->program_ = std::move(*program);
  p->vao_ = GlVertexArray();
  const AtmosphereTableSizes& s = p->tables_.sizes();
  p->transmittance_ =
      makeTable2d(s.transmittanceW, s.transmittanceH, p->tables_.transmittanceTable());
  const int w = s.scatteringNu * s.scatteringMuS;
  p->scattering_ = makeTable3d(w, s.scatteringMu, s.scatteringR, p->tables_.scatteringTable());
  p->mie_ = makeTable3d(w, s.scatteringMu, s.scatteringR, p->tables_.mieTable());
  p->depthFbo_ = GlFramebuffer();
  const GLuint id = p->program_.id();
  glUseProgram(id);
  glUniform1i(at(id, "uTransmittance"), 0);
  glUniform1i(at(id, "uScattering"), 1);
  glUniform1i(at(id, "uMie"), 2);
  glUniform1i(at(id, "uDepth"), 3);
  glUseProgram(0);
  return p;
}

void AtmospherePass::copyDepth(const DrawTarget& target) {
  if (target.width != depthWidth_ || target.height != depthHeight_) {
    depth_ = GlTexture();
    glBindTexture(GL_TEXTURE_2D, depth_.id());
    glTexImage2D(GL_TEXTURE_2D,
                 0,
                 kDepthFormat,
                 target.width,
                 target.height,
                 0,
                 GL_DEPTH_COMPONENT,
                 GL_FLOAT,
                 nullptr);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glBindTexture(GL_TEXTURE_2D, 0);
    glBindFramebuffer(GL_FRAMEBUFFER, depthFbo_.id());
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, depth_.id(), 0);
    glDrawBuffer(GL_NONE);
    glReadBuffer(GL_NONE);
    depthWidth_ = target.width;
    depthHeight_ = target.height;
  }
  glBindFramebuffer(GL_READ_FRAMEBUFFER, target.fbo);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, depthFbo_.id());
  glBlitFramebuffer(0,
                    0,
                    target.width,
                    target.height,
                    0,
                    0,
                    target.width,
                    target.height,
                    GL_DEPTH_BUFFER_BIT,
                    GL_NEAREST);
  glBindFramebuffer(GL_FRAMEBUFFER, target.fbo);
}

void AtmospherePass::setUniforms(const FrameContext& frame) {
  const GLuint id = program_.id();
  const AtmosphereParameters& p = tables_.parameters();
  const AtmosphereTableSizes& s = tables_.sizes();
  const Camera& cam = frame.camera;
  // The eye in sphere space (the polar axis stretched), in double; narrowed once.
  const glm::dvec3 scale(1.0, 1.0, polarStretch_);
  const glm::dvec3 eye = frame.eye * scale;
  const double r = glm::length(eye);
  const glm::dvec3 up = eye / r;
  const glm::dvec3 sun =
      frame.sun ? glm::normalize(glm::dvec3(frame.sun->x, frame.sun->y, frame.sun->z) * scale) : up;
  glm::dmat4 view = cam.view();
  view[3] = glm::dvec4(0.0, 0.0, 0.0, 1.0);
  const glm::mat4 inv(glm::inverse(cam.projection() * view));
  glUniformMatrix4fv(at(id, "uInvViewProj"), 1, GL_FALSE, &inv[0][0]);
  const bool fisheye = frame.fisheye != nullptr;
  glUniform1i(at(id, "uFisheye"), fisheye ? 1 : 0);
  if (fisheye) {
    const glm::mat3 toWorld(glm::dmat3(cam.right(), cam.up(), -cam.forward()));
    glUniformMatrix3fv(at(id, "uDomeToWorld"), 1, GL_FALSE, &toWorld[0][0]);
    const double alpha = cam.fisheyeHalfAngleRad();
    const double diameter = std::min(frame.framebufferWidth, frame.framebufferHeight);
    glUniform3f(at(id, "uFisheyeMap"),
                static_cast<float>(diameter / frame.framebufferWidth / alpha),
                static_cast<float>(diameter / frame.framebufferHeight / alpha),
                static_cast<float>(alpha));
  }
  const glm::vec3 forward(cam.forward());
  glUniform3f(at(id, "uForward"), forward.x, forward.y, forward.z);
  glUniform1f(at(id, "uNear"), static_cast<float>(cam.nearM()));
  glUniform1i(at(id, "uClipControl"), clipControl_ ? 1 : 0);
  glUniform3f(at(id, "uScale"), 1.0f, 1.0f, static_cast<float>(polarStretch_));
  glUniform3f(
      at(id, "uUp"), static_cast<float>(up.x), static_cast<float>(up.y), static_cast<float>(up.z));
  glUniform1f(at(id, "uEyeAltitude"), static_cast<float>(r - p.bottomRadiusM));
  glUniform3f(at(id, "uSun"),
              static_cast<float>(sun.x),
              static_cast<float>(sun.y),
              static_cast<float>(sun.z));
  const double bigH = std::sqrt(p.topAltitudeM * (2.0 * p.bottomRadiusM + p.topAltitudeM));
  glUniform4f(at(id, "uShell"),
              static_cast<float>(p.bottomRadiusM),
              static_cast<float>(p.topRadiusM()),
              static_cast<float>(p.topAltitudeM),
              static_cast<float>(bigH));
  glUniform4f(at(id, "uSizes"),
              static_cast<float>(s.scatteringNu),
              static_cast<float>(s.scatteringMuS),
              static_cast<float>(s.scatteringMu),
              static_cast<float>(s.scatteringR));
  glUniform4f(at(id, "uTexSizes"),
              static_cast<float>(s.transmittanceW),
              static_cast<float>(s.transmittanceH),
              static_cast<float>(p.muSMin),
              static_cast<float>(p.miePhaseG));
  const double alpha = p.sunAngularRadiusRad;
  glUniform4f(at(id, "uSunDisc"),
              static_cast<float>(std::cos(alpha)),
              static_cast<float>(1.0 / (std::numbers::pi * alpha * alpha)),
              static_cast<float>(exposure_),
              0.0f);
  glUniform3f(at(id, "uSolar"),
              static_cast<float>(p.solarIrradiance.x),
              static_cast<float>(p.solarIrradiance.y),
              static_cast<float>(p.solarIrradiance.z));
}

void AtmospherePass::draw(const FrameContext& frame) {
  copyDepth(frame.target);
  glDisable(GL_DEPTH_TEST);
  glDepthMask(GL_FALSE);
  glEnable(GL_BLEND);
  glBlendFunc(GL_ONE, GL_SRC1_COLOR);
  glUseProgram(program_.id());
  setUniforms(frame);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, transmittance_.id());
  glActiveTexture(GL_TEXTURE1);
  glBindTexture(GL_TEXTURE_3D, scattering_.id());
  glActiveTexture(GL_TEXTURE2);
  glBindTexture(GL_TEXTURE_3D, mie_.id());
  glActiveTexture(GL_TEXTURE3);
  glBindTexture(GL_TEXTURE_2D, depth_.id());
  glBindVertexArray(vao_.id());
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glBindVertexArray(0);
  glBindTexture(GL_TEXTURE_2D, 0);
  glActiveTexture(GL_TEXTURE0);
  glDisable(GL_BLEND);
  glDepthMask(GL_TRUE);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_GREATER);
}

} // namespace tellus::planet
