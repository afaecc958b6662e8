#include "GlobePass.hpp"

#include "Dome.hpp"
#include "GlShader.hpp"
#include "Shaders.hpp"

#include <tellus/planet/GpuVertex.hpp>
#include <tellus/values/ColourMap.hpp>

#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

namespace tellus::planet {

std::expected<std::unique_ptr<GlobePass>, std::string>
GlobePass::create(const GlCapabilities& gl, const GlobePassOptions& options, NodeMeshes& meshes) {
  std::unique_ptr<GlobePass> p(new GlobePass(meshes));
  // Double vertex positions where the GL has them (4.0+: ARB_gpu_shader_fp64; 64-bit vertex
  // attributes are core from 4.1), else the two-float path.
  p->fp64_ = gl.gl45 && options.fp64;
  std::string defines = p->fp64_ ? "#define TELLUS_FP64 1\n" : "";
  if (options.fisheye) defines += "#define TELLUS_FISHEYE 1\n";
  GLint units = 16;
  glGetIntegerv(GL_MAX_TEXTURE_IMAGE_UNITS, &units);
  // Unit 0 the base, then the overlays, the fade's, the colour maps'.
  p->overlaysPerPass_ = std::clamp(units - 3, 1, 8);
  if (options.overlaysPerPass > 0)
    p->overlaysPerPass_ = std::min(p->overlaysPerPass_, options.overlaysPerPass);
  std::string fragDefines = "#define TELLUS_OVERLAYS " + std::to_string(p->overlaysPerPass_) +
                            "\n#define TELLUS_OVERLAY_STEPS";
  for (int i = 0; i < p->overlaysPerPass_; ++i)
    fragDefines += " TELLUS_OVERLAY(" + std::to_string(i) + ")";
  fragDefines += "\n";
  const std::string header = gl.glslHeader();
  auto program = linkProgram(
      header + defines + kShader_planet_vert, header + fragDefines + kShader_planet_frag, "shader");
  if (!program) return std::unexpected(program.error());
  p->program_ = std::move(*program);
  const GLuint id = p->program_.id();
  p->uViewProj_ = glGetUniformLocation(id, "uViewProj");
  p->uEye_ = glGetUniformLocation(id, "uEye");
  p->uEyeHigh_ = glGetUniformLocation(id, "uEyeHigh");
  p->uEyeLow_ = glGetUniformLocation(id, "uEyeLow");
  p->uUv_ = glGetUniformLocation(id, "uUv");
  p->uTexture_ = glGetUniformLocation(id, "uTexture");
  p->uSun_ = glGetUniformLocation(id, "uSun");
  p->uBase_ = glGetUniformLocation(id, "uBase");
  p->uOverlayCount_ = glGetUniformLocation(id, "uOverlayCount");
  p->uOverlayUv_ = glGetUniformLocation(id, "uOverlayUv");
  p->uOverlayOpacity_ = glGetUniformLocation(id, "uOverlayOpacity");
  p->uOverlayNight_ = glGetUniformLocation(id, "uOverlayNight");
  p->uPolarScale_ = glGetUniformLocation(id, "uPolarScale");
  glUseProgram(id);
  for (int i = 0; i < p->overlaysPerPass_; ++i)
    glUniform1i(glGetUniformLocation(id, ("uOverlay[" + std::to_string(i) + "]").c_str()), 1 + i);
  p->initFade();
  p->initColourMaps();
  glUseProgram(0);
  return p;
}

// Fade-in (issue 23): the part's previous texture on the unit after the overlays'.
void GlobePass::initFade() {
  const GLuint id = program_.id();
  uFadeFrom_ = glGetUniformLocation(id, "uFadeFrom");
  uFadeUv_ = glGetUniformLocation(id, "uFadeUv");
  uFade_ = glGetUniformLocation(id, "uFade");
  uMorph_ = glGetUniformLocation(id, "uMorph");
  glUniform1i(uFadeFrom_, 1 + overlaysPerPass_);
}

void GlobePass::initColourMaps() {
  const GLuint id = program_.id();
  uOverlayValues_ = glGetUniformLocation(id, "uOverlayValues");
  uOverlayRange_ = glGetUniformLocation(id, "uOverlayRange");
  glUniform1i(glGetUniformLocation(id, "uColourMaps"), 2 + overlaysPerPass_);
  const auto maps = values::colourMaps();
  std::vector<std::uint8_t> rgba;
  for (const values::ColourMap& m : maps)
    for (const values::Rgb8& c : *m.table)
      rgba.insert(rgba.end(), {c[0], c[1], c[2], 255});
  colourMaps_ = GlTexture();
  glActiveTexture(GL_TEXTURE2 + static_cast<GLenum>(overlaysPerPass_));
  glBindTexture(GL_TEXTURE_2D, colourMaps_.id());
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexImage2D(GL_TEXTURE_2D,
               0,
               GL_RGBA8,
               256,
               static_cast<GLsizei>(maps.size()),
               0,
               GL_RGBA,
               GL_UNSIGNED_BYTE,
               rgba.data());
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glActiveTexture(GL_TEXTURE0);
}

void GlobePass::setFade(const DrawPart& p) {
  glUniform1f(uFade_, p.fadeFrom != nullptr ? p.fade : 1.0f);
  if (p.fadeFrom == nullptr) return;
  const std::array<float, 4> uv = uvUniform(p.fadeUv);
  glUniform4f(uFadeUv_, uv[0], uv[1], uv[2], uv[3]);
  glActiveTexture(GL_TEXTURE1 + static_cast<GLenum>(overlaysPerPass_));
  glBindTexture(GL_TEXTURE_2D, p.fadeFrom->id());
}

void GlobePass::setFrameUniforms(const FrameContext& frame) {
  if (cullBack_) { // node meshes wind counter-clockwise seen from outside
    glEnable(GL_CULL_FACE);
    glCullFace(GL_BACK);
  } else {
    glDisable(GL_CULL_FACE);
  }
  glUseProgram(program_.id());
  glUniform1i(uTexture_, 0);
  glActiveTexture(GL_TEXTURE2 + static_cast<GLenum>(overlaysPerPass_));
  glBindTexture(GL_TEXTURE_2D, colourMaps_.id());
  glActiveTexture(GL_TEXTURE0);
  // One view-projection for every node, rotation only (the eye at the origin); positions arrive
  // as doubles or high/low float pairs and the shader subtracts the eye's.
  glUniformMatrix4fv(uViewProj_, 1, GL_FALSE, &frame.viewProjection[0][0]);
  glUniform2f(uMorph_, static_cast<float>(morphScale_), morphScale_ > 0.0 ? 1.0f : 0.0f);
  if (fp64_) {
    glUniform3d(uEye_, frame.eye.x, frame.eye.y, frame.eye.z);
  } else {
    const SplitDouble x = splitDouble(frame.eye.x), y = splitDouble(frame.eye.y),
                      z = splitDouble(frame.eye.z);
    glUniform3f(uEyeHigh_, x.high, y.high, z.high);
    glUniform3f(uEyeLow_, x.low, y.low, z.low);
  }
  const double ab = frame.body.equatorialRadius() / frame.body.polarRadius();
  glUniform1f(uPolarScale_, static_cast<float>(ab * ab));
  if (frame.sun && frame.sunlight) {
    glUniform4f(uSun_,
                static_cast<float>(frame.sun->x),
                static_cast<float>(frame.sun->y),
                static_cast<float>(frame.sun->z),
                1.0f);
  } else {
    glUniform4f(uSun_, 0.0f, 0.0f, 0.0f, 0.0f);
  }
}

void GlobePass::draw(const FrameContext& frame) {
  setFrameUniforms(frame);
  if (frame.fisheye != nullptr)
    frame.fisheye->beginDirect(
        program_, frame.camera, frame.framebufferWidth, frame.framebufferHeight);
  const DrawList& list = frame.drawList;
  const auto k = static_cast<std::uint32_t>(overlaysPerPass_);
  const std::uint32_t passes = list.passes(k);
  frame.stats.passes = static_cast<int>(passes);
  for (std::uint32_t pass = 0; pass < passes; ++pass) {
    glUniform1f(uBase_, pass == 0 ? 1.0f : 0.0f);
    if (pass == 1) {
      glEnable(GL_BLEND);
      glBlendFuncSeparate(GL_ONE, GL_ONE_MINUS_SRC_ALPHA, GL_ZERO, GL_ONE);
      glDepthFunc(GL_GEQUAL);
      glDepthMask(GL_FALSE);
    }
    for (const DrawPart& p : list.parts) {
      if (!frame.target.draws(*p.node)) continue;
      const std::uint32_t from = std::min(p.overlayEnd, p.overlayBegin + pass * k);
      const std::uint32_t count = std::min(k, p.overlayEnd - from);
      if (pass > 0 && count == 0) continue;
      drawPart(p, list, from, count, frame.stats);
    }
  }
  if (passes > 1) {
    glDisable(GL_BLEND);
    glDepthFunc(GL_GREATER);
    glDepthMask(GL_TRUE);
  }
  glBindVertexArray(0);
  if (frame.fisheye != nullptr) frame.fisheye->endDirect(program_);
}

void GlobePass::drawPart(const DrawPart& p,
                         const DrawList& list,
                         std::uint32_t from,
                         std::uint32_t count,
                         RenderStats& stats) {
  std::array<GLfloat, 32> uvs{};
  std::array<GLfloat, 8> opacities{};
  std::array<GLfloat, 8> night{};
  std::array<GLfloat, 32> valueInfo{}; // per overlay: values?, map row, log?, transparent out?
  std::array<GLfloat, 16> ranges{};    // per overlay: low, high (log: log10)
  const GpuMesh& m = meshes_.meshFor(*p.node, stats);
  const std::array<float, 4> uv = uvUniform(p.uv);
  glUniform4f(uUv_, uv[0], uv[1], uv[2], uv[3]);
  for (std::uint32_t i = 0; i < count; ++i) {
    const OverlayBinding& b = list.bindings[from + i];
    glActiveTexture(GL_TEXTURE1 + i);
    glBindTexture(GL_TEXTURE_2D, b.texture->id());
    const std::array<float, 4> u = uvUniform(b.uv);
    std::copy(u.begin(), u.end(), uvs.begin() + static_cast<std::ptrdiff_t>(4 * i));
    opacities[i] = b.opacity;
    night[i] = b.night ? 1.0f : 0.0f;
    if (b.values) {
      valueInfo[4 * i] = 1.0f;
      valueInfo[4 * i + 1] = static_cast<GLfloat>(b.values->mapRow);
      valueInfo[4 * i + 2] = b.values->log ? 1.0f : 0.0f;
      valueInfo[4 * i + 3] = b.values->transparentOut ? 1.0f : 0.0f;
      ranges[2 * i] = static_cast<GLfloat>(b.values->low);
      ranges[2 * i + 1] = static_cast<GLfloat>(b.values->high);
    }
  }
  setFade(p);
  glUniform1i(uOverlayCount_, static_cast<GLint>(count));
  if (count > 0) {
    glUniform4fv(uOverlayUv_, static_cast<GLsizei>(count), uvs.data());
    glUniform1fv(uOverlayOpacity_, static_cast<GLsizei>(count), opacities.data());
    glUniform1fv(uOverlayNight_, static_cast<GLsizei>(count), night.data());
    glUniform4fv(uOverlayValues_, static_cast<GLsizei>(count), valueInfo.data());
    glUniform2fv(uOverlayRange_, static_cast<GLsizei>(count), ranges.data());
  }
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, p.texture->id());
  glBindVertexArray(m.vao.id());
  const std::uint32_t first = m.quadrantStart[static_cast<std::size_t>(p.firstQuadrant)];
  const std::uint32_t last = m.quadrantStart[static_cast<std::size_t>(p.lastQuadrant)];
  glDrawElements(
      GL_TRIANGLES,
      static_cast<GLsizei>(last - first),
      GL_UNSIGNED_INT,
      reinterpret_cast<const void*>(static_cast<std::uintptr_t>(first) * sizeof(std::uint32_t)));
}

} // namespace tellus::planet
