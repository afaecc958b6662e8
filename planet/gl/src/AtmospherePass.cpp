#include "AtmospherePass.hpp"

#include "Depth.hpp"
#include "Dome.hpp"
#include "GlShader.hpp"
#include "Shaders.hpp"

#include <tellus/planet/AtmosphereCache.hpp>

#include <glm/glm.hpp>

#include <array>
#include <cmath>
#include <cstdio>
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

/** An empty RGBA16F table the view tables' builder renders into (2D: depth 0). */
GlTexture makeTarget(int w, int h, int d) {
  GlTexture t;
  const GLenum kind = d > 0 ? GL_TEXTURE_3D : GL_TEXTURE_2D;
  glBindTexture(kind, t.id());
  if (d > 0)
    glTexImage3D(kind, 0, GL_RGBA16F, w, h, d, 0, GL_RGBA, GL_FLOAT, nullptr);
  else
    glTexImage2D(kind, 0, GL_RGBA16F, w, h, 0, GL_RGBA, GL_FLOAT, nullptr);
  glTexParameteri(kind, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(kind, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(kind, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(kind, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glTexParameteri(kind, GL_TEXTURE_WRAP_R, GL_CLAMP_TO_EDGE);
  glBindTexture(kind, 0);
  return t;
}

constexpr std::array<GLenum, 3> kTargets{
    GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, GL_COLOR_ATTACHMENT2};

} // namespace

AtmospherePass::AtmospherePass(
    AtmosphereTables tables, double exposure, const Geodesy& body, bool clipControl, int divisor)
    : tables_(std::move(tables)), exposure_(exposure),
      polarStretch_(body.equatorialRadius() / body.polarRadius()), clipControl_(clipControl),
      divisor_(divisor) {}

std::expected<std::unique_ptr<AtmospherePass>, std::string>
AtmospherePass::create(const GlCapabilities& gl,
                       AtmosphereParameters parameters,
                       double exposure,
                       const Geodesy& body,
                       const std::string& cacheDir,
                       int divisor) {
  if (parameters.bottomRadiusM <= 0.0) parameters.bottomRadiusM = body.equatorialRadius();
  if (const std::string bad = parameters.validate(); !bad.empty())
    return std::unexpected("atmosphere: " + bad);
  if (!(exposure > 0.0 && std::isfinite(exposure)))
    return std::unexpected(std::string("atmosphere: the exposure must be positive"));
  AtmosphereCacheResult tables = cachedAtmosphereTables(cacheDir, parameters);
  if (!tables.note.empty() && !cacheDir.empty() && tables.note.rfind("no file", 0) != 0)
    std::fprintf(stderr, "tellus: atmosphere tables: %s (computed anew)\n", tables.note.c_str());
  return create(gl, std::move(tables.tables), exposure, body, divisor);
}

std::expected<std::unique_ptr<AtmospherePass>, std::string>
AtmospherePass::create(const GlCapabilities& gl,
                       AtmosphereTables tables,
                       double exposure,
                       const Geodesy& body,
                       int divisor) {
  if (!(exposure > 0.0 && std::isfinite(exposure)))
    return std::unexpected(std::string("atmosphere: the exposure must be positive"));
  if (divisor != 1 && divisor != 2 && divisor != 4)
    return std::unexpected(std::string("atmosphere: the resolution's divisor must be 1, 2 or 4"));
  std::unique_ptr<AtmospherePass> p(
      new AtmospherePass(std::move(tables), exposure, body, gl.clipControl, divisor));
  if (auto made = p->makeGl(gl); !made) return std::unexpected(made.error());
  return p;
}

std::expected<void, std::string> AtmospherePass::makeGl(const GlCapabilities& gl) {
  const std::string header = gl.glslHeader();
  const std::string common = kShader_atmosphere_common_glsl;
  const std::string split = divisor_ > 1 ? "#define TELLUS_ATMOSPHERE_SPLIT 1\n" : "";
  auto program = linkProgram(header + kShader_atmosphere_vert,
                             header + split + common + kShader_atmosphere_frag,
                             "atmosphere shader");
  if (!program) return std::unexpected(program.error());
  program_ = std::move(*program);
  if (divisor_ > 1) {
    auto composite = linkProgram(header + kShader_atmosphere_vert,
                                 header + "#define TELLUS_ATMOSPHERE_COMPOSITE 1\n" + common +
                                     kShader_atmosphere_frag,
                                 "atmosphere composite shader");
    if (!composite) return std::unexpected(composite.error());
    compositeProgram_ = std::move(*composite);
    hazeFbo_ = GlFramebuffer();
  }
  auto lut = linkProgram(header + kShader_atmosphere_vert,
                         header + common + kShader_atmosphere_lut_frag,
                         "atmosphere view-table shader");
  if (!lut) return std::unexpected(lut.error());
  lutProgram_ = std::move(*lut);
  vao_ = GlVertexArray();
  const AtmosphereTableSizes& s = tables_.sizes();
  transmittance_ = makeTable2d(s.transmittanceW, s.transmittanceH, tables_.transmittanceTable());
  const int w = s.scatteringNu * s.scatteringMuS;
  scattering_ = makeTable3d(w, s.scatteringMu, s.scatteringR, tables_.scatteringTable());
  mie_ = makeTable3d(w, s.scatteringMu, s.scatteringR, tables_.mieTable());
  depthFbo_ = GlFramebuffer();
  if (!makeViewTables())
    return std::unexpected(std::string("atmosphere: the view tables cannot be rendered into"));
  for (const GLuint id : {program_.id(), compositeProgram_.id()}) {
    if (id == 0) continue;
    glUseProgram(id);
    setShellUniforms(id);
    glUniform1i(at(id, "uDepth"), 0);
    glUniform1i(at(id, "uSkyRayleigh"), 1);
    glUniform1i(at(id, "uSkyMie"), 2);
    glUniform1i(at(id, "uSkyTransmittance"), 3);
    glUniform1i(at(id, "uAirRayleigh"), 4);
    glUniform1i(at(id, "uAirMie"), 5);
    glUniform1i(at(id, "uAirTransmittance"), 6);
    glUniform1i(at(id, "uGlow"), 7);
    glUniform1i(at(id, "uFactor"), 8);
    glUniform1i(at(id, "uSunLight"), 9);
    glUniform1i(at(id, "uDivisor"), divisor_);
    glUniform2f(at(id, "uSkyLut"), float(kSkyAzimuth), float(s.scatteringMu));
  }
  const GLuint lid = lutProgram_.id();
  glUseProgram(lid);
  setShellUniforms(lid);
  glUniform1i(at(lid, "uTransmittance"), 0);
  glUniform1i(at(lid, "uScattering"), 1);
  glUniform1i(at(lid, "uMie"), 2);
  glUseProgram(0);
  return {};
}

bool AtmospherePass::makeViewTables() {
  const int zenith = tables_.sizes().scatteringMu;
  skyRayleigh_ = makeTarget(kSkyAzimuth, zenith, 0);
  skyMie_ = makeTarget(kSkyAzimuth, zenith, 0);
  skyTransmittance_ = makeTarget(kSkyAzimuth, zenith, 0);
  airRayleigh_ = makeTarget(kAirAzimuth, kAirZenith, kAirSlices);
  airMie_ = makeTarget(kAirAzimuth, kAirZenith, kAirSlices);
  airTransmittance_ = makeTarget(kAirAzimuth, kAirZenith, kAirSlices);
  skyFbo_ = GlFramebuffer();
  glBindFramebuffer(GL_FRAMEBUFFER, skyFbo_.id());
  const std::array<GLuint, 3> sky{skyRayleigh_.id(), skyMie_.id(), skyTransmittance_.id()};
  for (std::size_t i = 0; i < 3; ++i)
    glFramebufferTexture2D(GL_FRAMEBUFFER, kTargets[i], GL_TEXTURE_2D, sky[i], 0);
  glDrawBuffers(3, kTargets.data());
  const bool skyComplete = glCheckFramebufferStatus(GL_FRAMEBUFFER) == GL_FRAMEBUFFER_COMPLETE;
  airFbo_ = GlFramebuffer();
  glBindFramebuffer(GL_FRAMEBUFFER, airFbo_.id());
  const std::array<GLuint, 3> air{airRayleigh_.id(), airMie_.id(), airTransmittance_.id()};
  for (std::size_t i = 0; i < 3; ++i)
    glFramebufferTextureLayer(GL_FRAMEBUFFER, kTargets[i], air[i], 0, 0);
  glDrawBuffers(3, kTargets.data());
  const bool airComplete = glCheckFramebufferStatus(GL_FRAMEBUFFER) == GL_FRAMEBUFFER_COMPLETE;
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  return skyComplete && airComplete;
}

void AtmospherePass::setShellUniforms(GLuint id) {
  const AtmosphereParameters& p = tables_.parameters();
  const AtmosphereTableSizes& s = tables_.sizes();
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
  glUniform4f(at(id, "uAirLut"),
              float(kAirAzimuth),
              float(kAirZenith),
              float(kAirSlices),
              static_cast<float>(kAirLogC));
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
    if (divisor_ > 1) makeHaze();
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

bool AtmospherePass::makeHaze() {
  hazeWidth_ = (depthWidth_ + divisor_ - 1) / divisor_;
  hazeHeight_ = (depthHeight_ + divisor_ - 1) / divisor_;
  auto colour = [&] {
    GlTexture t;
    glBindTexture(GL_TEXTURE_2D, t.id());
    glTexImage2D(
        GL_TEXTURE_2D, 0, GL_RGBA8, hazeWidth_, hazeHeight_, 0, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glBindTexture(GL_TEXTURE_2D, 0);
    return t;
  };
  glow_ = colour();
  factor_ = colour();
  sunLight_ = colour();
  glBindFramebuffer(GL_FRAMEBUFFER, hazeFbo_.id());
  const std::array<GLuint, 3> haze{glow_.id(), factor_.id(), sunLight_.id()};
  for (std::size_t i = 0; i < 3; ++i)
    glFramebufferTexture2D(GL_FRAMEBUFFER, kTargets[i], GL_TEXTURE_2D, haze[i], 0);
  glDrawBuffers(3, kTargets.data());
  return glCheckFramebufferStatus(GL_FRAMEBUFFER) == GL_FRAMEBUFFER_COMPLETE;
}

AtmospherePass::EyeFrame AtmospherePass::eyeFrame(const FrameContext& frame) const {
  // The eye in sphere space (the polar axis stretched), in double; narrowed once.
  const glm::dvec3 scale(1.0, 1.0, polarStretch_);
  const glm::dvec3 eye = frame.eye * scale;
  const double r = glm::length(eye);
  EyeFrame e;
  e.up = eye / r;
  e.altitude = r - tables_.parameters().bottomRadiusM;
  e.sun = frame.sun ? glm::normalize(glm::dvec3(frame.sun->x, frame.sun->y, frame.sun->z) * scale)
                    : e.up;
  // The sun's horizontal direction; at the zenith or the nadir any horizontal one.
  glm::dvec3 side = e.sun - glm::dot(e.sun, e.up) * e.up;
  if (glm::length(side) < 1e-9) {
    side = glm::cross(e.up, std::abs(e.up.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0));
  }
  e.side = glm::normalize(side);
  e.normal = glm::cross(e.up, e.side);
  return e;
}

void AtmospherePass::updateViewTables(float altitude, float muS) {
  if (tablesMade_ && altitude == lastAltitude_ && muS == lastMuS_) return;
  GLint viewport[4];
  glGetIntegerv(GL_VIEWPORT, viewport);
  const GLboolean scissor = glIsEnabled(GL_SCISSOR_TEST);
  glDisable(GL_SCISSOR_TEST);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_BLEND);
  glBlendFunc(GL_ONE, GL_ZERO); // dual-source factors forbid three draw buffers even unblended
  const GLuint id = lutProgram_.id();
  glUseProgram(id);
  glUniform1f(at(id, "uEyeAltitude"), altitude);
  glUniform1f(at(id, "uMuS"), muS);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, transmittance_.id());
  glActiveTexture(GL_TEXTURE1);
  glBindTexture(GL_TEXTURE_3D, scattering_.id());
  glActiveTexture(GL_TEXTURE2);
  glBindTexture(GL_TEXTURE_3D, mie_.id());
  glBindVertexArray(vao_.id());
  const GLint lut = at(id, "uLut");
  const int zenith = tables_.sizes().scatteringMu;
  glBindFramebuffer(GL_FRAMEBUFFER, skyFbo_.id());
  glViewport(0, 0, kSkyAzimuth, zenith);
  glUniform4f(lut, float(kSkyAzimuth), float(zenith), 0.0f, 0.0f);
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glBindFramebuffer(GL_FRAMEBUFFER, airFbo_.id());
  glViewport(0, 0, kAirAzimuth, kAirZenith);
  const std::array<GLuint, 3> air{airRayleigh_.id(), airMie_.id(), airTransmittance_.id()};
  for (int k = 0; k < kAirSlices; ++k) {
    for (std::size_t i = 0; i < 3; ++i)
      glFramebufferTextureLayer(GL_FRAMEBUFFER, kTargets[i], air[i], 0, k);
    glUniform4f(lut, float(kAirAzimuth), float(kAirZenith), float(kAirSlices), float(k));
    glDrawArrays(GL_TRIANGLES, 0, 3);
  }
  glViewport(viewport[0], viewport[1], viewport[2], viewport[3]);
  if (scissor) glEnable(GL_SCISSOR_TEST);
  tablesMade_ = true;
  lastAltitude_ = altitude;
  lastMuS_ = muS;
  ++updates_;
}

void AtmospherePass::setUniforms(GLuint id, const FrameContext& frame, const EyeFrame& e) {
  const AtmosphereParameters& p = tables_.parameters();
  const Camera& cam = frame.camera;
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
  glUniform2f(at(id, "uTarget"),
              static_cast<float>(frame.target.width),
              static_cast<float>(frame.target.height));
  const glm::vec3 forward(cam.forward());
  glUniform3f(at(id, "uForward"), forward.x, forward.y, forward.z);
  glUniform1f(at(id, "uNear"), static_cast<float>(cam.nearM()));
  glUniform1i(at(id, "uClipControl"), clipControl_ ? 1 : 0);
  glUniform3f(at(id, "uScale"), 1.0f, 1.0f, static_cast<float>(polarStretch_));
  auto vec = [&](const char* name, const glm::dvec3& v) {
    glUniform3f(
        at(id, name), static_cast<float>(v.x), static_cast<float>(v.y), static_cast<float>(v.z));
  };
  vec("uUp", e.up);
  vec("uSun", e.sun);
  vec("uSunSide", e.side);
  vec("uSunNormal", e.normal);
  vec("uSolar", p.solarIrradiance);
  glUniform1f(at(id, "uEyeAltitude"), static_cast<float>(e.altitude));
  // The eye's constants of the zenith map (shaders/atmosphere.frag, zenithOf), in double.
  const double b = p.bottomRadiusM, a = p.topAltitudeM, t = p.topRadiusM();
  const double h = std::max(e.altitude, 0.0), r = b + h;
  const double rho = std::sqrt(h * (2.0 * b + h));
  const double bigH = std::sqrt(a * (2.0 * b + a));
  const bool inside = static_cast<float>(e.altitude) <= static_cast<float>(a);
  glUniform4f(at(id, "uEye"),
              static_cast<float>(r),
              static_cast<float>(h * (2.0 * b + h)),
              static_cast<float>((a - h) * (t + r)),
              inside ? 1.0f : 0.0f);
  auto inverse = [](double x) { return x > 0.0 ? 1.0 / x : 0.0; };
  glUniform4f(at(id, "uZenith"),
              static_cast<float>(h),
              static_cast<float>(inverse(rho - h)),
              static_cast<float>(a - h),
              static_cast<float>(inverse(rho + bigH - (a - h))));
  const double alpha = p.sunAngularRadiusRad;
  glUniform4f(at(id, "uSunDisc"),
              static_cast<float>(std::cos(alpha)),
              static_cast<float>(1.0 / (std::numbers::pi * alpha * alpha)),
              static_cast<float>(exposure_),
              0.0f);
}

void AtmospherePass::draw(const FrameContext& frame) {
  const EyeFrame e = eyeFrame(frame);
  updateViewTables(static_cast<float>(e.altitude), static_cast<float>(glm::dot(e.up, e.sun)));
  copyDepth(frame.target);
  glDisable(GL_DEPTH_TEST);
  glDepthMask(GL_FALSE);
  std::array<std::pair<GLenum, GLuint>, 10> textures{{{GL_TEXTURE_2D, depth_.id()},
                                                      {GL_TEXTURE_2D, skyRayleigh_.id()},
                                                      {GL_TEXTURE_2D, skyMie_.id()},
                                                      {GL_TEXTURE_2D, skyTransmittance_.id()},
                                                      {GL_TEXTURE_3D, airRayleigh_.id()},
                                                      {GL_TEXTURE_3D, airMie_.id()},
                                                      {GL_TEXTURE_3D, airTransmittance_.id()},
                                                      {GL_TEXTURE_2D, 0},
                                                      {GL_TEXTURE_2D, 0},
                                                      {GL_TEXTURE_2D, 0}}};
  for (std::size_t i = 0; i < textures.size(); ++i) {
    glActiveTexture(GL_TEXTURE0 + static_cast<GLenum>(i));
    glBindTexture(textures[i].first, textures[i].second);
  }
  glBindVertexArray(vao_.id());
  if (divisor_ > 1) { // the haze's textures first, unblended, at their size
    GLint viewport[4];
    glGetIntegerv(GL_VIEWPORT, viewport);
    glBindFramebuffer(GL_FRAMEBUFFER, hazeFbo_.id());
    glViewport(0, 0, hazeWidth_, hazeHeight_);
    glDisable(GL_BLEND);
    glBlendFunc(GL_ONE, GL_ZERO); // dual-source factors forbid three draw buffers
    glUseProgram(program_.id());
    setUniforms(program_.id(), frame, e);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glBindFramebuffer(GL_FRAMEBUFFER, frame.target.fbo);
    glViewport(viewport[0], viewport[1], viewport[2], viewport[3]);
    // Sampled only now: bound while they are drawn into, they would be a feedback loop.
    const std::array<GLuint, 3> haze{glow_.id(), factor_.id(), sunLight_.id()};
    for (std::size_t i = 0; i < haze.size(); ++i) {
      glActiveTexture(GL_TEXTURE7 + static_cast<GLenum>(i));
      glBindTexture(GL_TEXTURE_2D, haze[i]);
      textures[7 + i].second = haze[i];
    }
  }
  const GLuint id = divisor_ > 1 ? compositeProgram_.id() : program_.id();
  glEnable(GL_BLEND);
  glBlendFunc(GL_ONE, GL_SRC1_COLOR);
  glUseProgram(id);
  setUniforms(id, frame, e);
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glBindVertexArray(0);
  for (std::size_t i = textures.size(); i-- > 0;) {
    glActiveTexture(GL_TEXTURE0 + static_cast<GLenum>(i));
    glBindTexture(textures[i].first, 0);
  }
  glDisable(GL_BLEND);
  glDepthMask(GL_TRUE);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_GREATER);
}

} // namespace tellus::planet
