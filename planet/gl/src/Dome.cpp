#include "Dome.hpp"

#include "GlShader.hpp"
#include "Shaders.hpp"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

namespace tellus::planet {

namespace {

/** The direction through the centre of face pixel (i, j) (bottom-up), in the cube's frame. */
glm::dvec3 faceDirection(const CubeFace& f, int faceSize, double i, double j) noexcept {
  const glm::dvec3 right = glm::cross(f.forward, f.up);
  const double x = (i + 0.5) / faceSize * 2.0 - 1.0, y = (j + 0.5) / faceSize * 2.0 - 1.0;
  return glm::normalize(f.forward + x * right + y * f.up);
}

} // namespace

const std::array<CubeFace, 6>& cubeFaces() noexcept {
  // GL's cube-map layout (the spec's face selection table): a face's s axis runs along
  // forward x up, its t axis along up.
  static const std::array<CubeFace, 6> faces{{
      {{1, 0, 0}, {0, -1, 0}},
      {{-1, 0, 0}, {0, -1, 0}},
      {{0, 1, 0}, {0, 0, 1}},
      {{0, -1, 0}, {0, 0, -1}},
      {{0, 0, 1}, {0, -1, 0}},
      {{0, 0, -1}, {0, -1, 0}},
  }};
  return faces;
}

FaceRect faceRegion(const CubeFace& face, int faceSize, double halfAngleRad) noexcept {
  // Sampled on a grid of the face's pixels (every step-th, and the last): the region's bounding
  // box in whole steps, grown by a step and a few pixels for the bilinear taps at its border.
  const int step = std::max(1, faceSize / 256);
  const double cosLimit = std::cos(std::min(halfAngleRad, 3.14159));
  int x0 = faceSize, y0 = faceSize, x1 = -1, y1 = -1;
  for (int j = 0; j < faceSize + step; j += step)
    for (int i = 0; i < faceSize + step; i += step) {
      const int ci = std::min(i, faceSize - 1), cj = std::min(j, faceSize - 1);
      const glm::dvec3 d = faceDirection(face, faceSize, ci, cj);
      // Within the cone (theta <= alpha) means -d.z >= cos(alpha); a little slack near its edge.
      if (-d.z < cosLimit - 0.02) continue;
      x0 = std::min(x0, ci);
      y0 = std::min(y0, cj);
      x1 = std::max(x1, ci);
      y1 = std::max(y1, cj);
    }
  if (x1 < 0) return {};
  const int grow = step + 1;
  return {std::max(0, x0 - grow),
          std::max(0, y0 - grow),
          std::min(faceSize, x1 + grow + 1),
          std::min(faceSize, y1 + grow + 1)};
}

std::expected<std::unique_ptr<Dome>, std::string>
Dome::create(int faceSize, const std::string& glslHeader, bool allocateFaces) {
  if (faceSize < 8 || faceSize > 16384)
    return std::unexpected(std::string("the dome's face size must be 8 to 16384 pixels"));
  std::unique_ptr<Dome> d(new Dome());
  d->size_ = faceSize;
  auto program =
      linkProgram(glslHeader + kShader_dome_vert, glslHeader + kShader_dome_frag, "dome shader");
  if (!program) return std::unexpected(program.error());
  d->program_ = std::move(*program);
  d->uCube_ = glGetUniformLocation(d->program_.id(), "uCube");
  d->uCircle_ = glGetUniformLocation(d->program_.id(), "uCircle");
  d->uViewport_ = glGetUniformLocation(d->program_.id(), "uViewport");
  d->vao_ = GlVertexArray();
  d->meshVbo_ = GlBuffer();
  d->meshEbo_ = GlBuffer();
  auto mask = linkProgram(
      glslHeader + kShader_dome_mask_vert, glslHeader + kShader_dome_mask_frag, "dome mask shader");
  if (!mask) return std::unexpected(mask.error());
  d->maskProgram_ = std::move(*mask);
  d->uMaskViewport_ = glGetUniformLocation(d->maskProgram_.id(), "uViewport");
  d->uMaskCircle_ = glGetUniformLocation(d->maskProgram_.id(), "uCircle");
  d->maskVao_ = GlVertexArray();
  d->maskVbo_ = GlBuffer();
  if (glGetError() != GL_NO_ERROR)
    return std::unexpected(std::string("OpenGL error while setting up the dome"));
  if (allocateFaces) {
    if (auto r = d->allocateFaces(); !r) return std::unexpected(r.error());
  }
  return d;
}

std::expected<void, std::string> Dome::allocateFaces() {
  if (facesAllocated()) return {};
  const int faceSize = size_;
  // Filtering across face borders reads the neighbouring face (core since 3.2).
  glEnable(GL_TEXTURE_CUBE_MAP_SEAMLESS);
  cube_ = GlTexture();
  glBindTexture(GL_TEXTURE_CUBE_MAP, cube_.id());
  for (int i = 0; i < 6; ++i)
    glTexImage2D(GL_TEXTURE_CUBE_MAP_POSITIVE_X + static_cast<GLenum>(i),
                 0,
                 GL_RGBA8,
                 faceSize,
                 faceSize,
                 0,
                 GL_RGBA,
                 GL_UNSIGNED_BYTE,
                 nullptr);
  glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MAX_LEVEL, 0);
  glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_WRAP_R, GL_CLAMP_TO_EDGE);
  glBindTexture(GL_TEXTURE_CUBE_MAP, 0);
  // One depth buffer for the faces (each is cleared before it is drawn): float, reversed Z.
  depth_ = GlRenderbuffer();
  glBindRenderbuffer(GL_RENDERBUFFER, depth_.id());
  glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT32F, faceSize, faceSize);
  for (GlFramebuffer& fbo : fbos_)
    fbo = GlFramebuffer();
  for (int i = 0; i < 6; ++i) {
    glBindFramebuffer(GL_FRAMEBUFFER, fbos_[static_cast<std::size_t>(i)].id());
    glFramebufferTexture2D(GL_FRAMEBUFFER,
                           GL_COLOR_ATTACHMENT0,
                           GL_TEXTURE_CUBE_MAP_POSITIVE_X + static_cast<GLenum>(i),
                           cube_.id(),
                           0);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth_.id());
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
      glBindFramebuffer(GL_FRAMEBUFFER, 0);
      freeFaces();
      return std::unexpected(std::string("the dome's cube face framebuffer is incomplete"));
    }
  }
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  if (glGetError() != GL_NO_ERROR) {
    freeFaces();
    return std::unexpected("OpenGL error while making the dome's " + std::to_string(faceSize) +
                           "-pixel cube faces (" + std::to_string(bytesOfFaces(faceSize) >> 20) +
                           " MiB; out of GPU memory?)");
  }
  return {};
}

void Dome::freeFaces() {
  for (GlFramebuffer& fbo : fbos_)
    fbo.reset();
  depth_.reset();
  cube_.reset();
}

void Dome::buildMesh(double halfAngleRad, double radiusPx) {
  // Rings of equal angle (64 up to the rim, one more a pixel and a half beyond it so the circle's
  // edge pixels are covered), 256 segments around; at the centre a fan. Directions in double,
  // then float. Interpolating a direction linearly across a cell of 1.4 x 1.4 degrees moves a
  // pixel by about 0.05 px at the rim of a 4k dome.
  constexpr int kRings = 64, kSegments = 256;
  const double outer = 1.0 + 1.5 / std::max(1.0, radiusPx);
  std::vector<float> v;
  std::vector<std::uint32_t> idx;
  auto vertex = [&](double r, double phi) {
    const double theta = r * halfAngleRad;
    v.insert(v.end(),
             {static_cast<float>(r * std::cos(phi)),
              static_cast<float>(r * std::sin(phi)),
              static_cast<float>(std::sin(theta) * std::cos(phi)),
              static_cast<float>(std::sin(theta) * std::sin(phi)),
              static_cast<float>(-std::cos(theta))});
  };
  vertex(0.0, 0.0);
  for (int k = 1; k <= kRings + 1; ++k) {
    const double r = k <= kRings ? static_cast<double>(k) / kRings : outer;
    for (int j = 0; j < kSegments; ++j)
      vertex(r, 2.0 * std::numbers::pi * j / kSegments);
  }
  auto at = [](int ring, int seg) {
    return static_cast<std::uint32_t>(1 + (ring - 1) * kSegments + (seg % kSegments));
  };
  for (int j = 0; j < kSegments; ++j)
    idx.insert(idx.end(), {0u, at(1, j), at(1, j + 1)});
  for (int k = 1; k <= kRings; ++k)
    for (int j = 0; j < kSegments; ++j)
      idx.insert(
          idx.end(),
          {at(k, j), at(k + 1, j), at(k + 1, j + 1), at(k, j), at(k + 1, j + 1), at(k, j + 1)});
  glBindVertexArray(vao_.id());
  glBindBuffer(GL_ARRAY_BUFFER, meshVbo_.id());
  glBufferData(
      GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(v.size() * sizeof(float)), v.data(), GL_STATIC_DRAW);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, meshEbo_.id());
  glBufferData(GL_ELEMENT_ARRAY_BUFFER,
               static_cast<GLsizeiptr>(idx.size() * sizeof(std::uint32_t)),
               idx.data(),
               GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, 5 * sizeof(float), nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1,
                        3,
                        GL_FLOAT,
                        GL_FALSE,
                        5 * sizeof(float),
                        reinterpret_cast<const void*>(2 * sizeof(float)));
  glBindVertexArray(0);
  meshIndices_ = static_cast<GLsizei>(idx.size());
  meshFor_ = halfAngleRad;
  meshRadius_ = radiusPx;
}

std::expected<void, std::string> Dome::render(
    const Camera& fisheye, const DrawFace& drawFace, GLuint target, int width, int height) {
  if (auto r = allocateFaces(); !r) return r;
  const double alpha = fisheye.fisheyeHalfAngleRad();
  const glm::dvec3 right = fisheye.right(), up = fisheye.up(), back = -fisheye.forward();
  auto toWorld = [&](const glm::dvec3& v) { return v.x * right + v.y * up + v.z * back; };
  facesDrawn_ = 0;
  if (alpha != regionsFor_) { // once per field of view (a few hundred thousand directions)
    for (std::size_t i = 0; i < 6; ++i)
      regions_[i] = faceRegion(cubeFaces()[i], size_, alpha);
    regionsFor_ = alpha;
  }
  for (std::size_t i = 0; i < 6; ++i) {
    const CubeFace& f = cubeFaces()[i];
    const FaceRect& r = regions_[i];
    if (r.x1 <= r.x0 || r.y1 <= r.y0) continue;
    const Camera face(fisheye, toWorld(f.forward), toWorld(f.up), {size_, size_}, 90.0);
    glEnable(GL_SCISSOR_TEST);
    glScissor(r.x0, r.y0, r.x1 - r.x0, r.y1 - r.y0);
    drawFace(face, DrawTarget{fbos_[i].id(), size_, size_, &face.frustum()});
    glDisable(GL_SCISSOR_TEST);
    ++facesDrawn_;
  }
  // The warp: black everywhere, then the circle from the cube (a polygon just around it; the
  // shader leaves what lies outside the circle black).
  glBindFramebuffer(GL_FRAMEBUFFER, target);
  glViewport(0, 0, width, height);
  glClearColor(0.0f, 0.0f, 0.0f, 1.0f);
  glClear(GL_COLOR_BUFFER_BIT);
  glDisable(GL_DEPTH_TEST);
  glUseProgram(program_.id());
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_CUBE_MAP, cube_.id());
  glUniform1i(uCube_, 0);
  const double diameter = std::min(width, height);
  if (alpha != meshFor_ || 0.5 * diameter != meshRadius_) buildMesh(alpha, 0.5 * diameter);
  glUniform3f(uCircle_,
              static_cast<float>(0.5 * width),
              static_cast<float>(0.5 * height),
              static_cast<float>(0.5 * diameter));
  glUniform2f(uViewport_, static_cast<float>(width), static_cast<float>(height));
  glBindVertexArray(vao_.id());
  glDrawElements(GL_TRIANGLES, meshIndices_, GL_UNSIGNED_INT, nullptr);
  glBindVertexArray(0);
  glBindTexture(GL_TEXTURE_CUBE_MAP, 0);
  glEnable(GL_DEPTH_TEST);
  return {};
}

void Dome::beginDirect(const GlProgram& nodeProgram, const Camera& fisheye, int width, int height) {
  if (&nodeProgram != directProgram_) {
    uFisheye_ = glGetUniformLocation(nodeProgram.id(), "uFisheye");
    uDomeRotation_ = glGetUniformLocation(nodeProgram.id(), "uDomeRotation");
    uDomeMap_ = glGetUniformLocation(nodeProgram.id(), "uDomeMap");
    directProgram_ = &nodeProgram;
  }
  // Rows right, up, -forward (the view matrix's rotation): q = R p; GL matrices are column-major.
  const glm::dvec3 r = fisheye.right(), u = fisheye.up(), b = -fisheye.forward();
  const std::array<GLfloat, 9> rotation{static_cast<GLfloat>(r.x),
                                        static_cast<GLfloat>(u.x),
                                        static_cast<GLfloat>(b.x),
                                        static_cast<GLfloat>(r.y),
                                        static_cast<GLfloat>(u.y),
                                        static_cast<GLfloat>(b.y),
                                        static_cast<GLfloat>(r.z),
                                        static_cast<GLfloat>(u.z),
                                        static_cast<GLfloat>(b.z)};
  const double alpha = fisheye.fisheyeHalfAngleRad();
  const double diameter = std::min(width, height);
  // NDC per radian: the rim (theta = alpha) lands at the circle's radius, diameter / 2 pixels.
  const double perRadX = diameter / static_cast<double>(width) / alpha;
  const double perRadY = diameter / static_cast<double>(height) / alpha;
  // The clip angle: a few of the fisheye's pixels beyond the rim (the mask blackens them).
  const double clip = alpha + kDirectClipMarginPx / fisheye.pixelsPerRadian();
  glUniform1i(uFisheye_, 1);
  glUniformMatrix3fv(uDomeRotation_, 1, GL_FALSE, rotation.data());
  glUniform4f(uDomeMap_,
              static_cast<float>(perRadX),
              static_cast<float>(perRadY),
              static_cast<float>(clip),
              static_cast<float>(fisheye.nearM()));
  glEnable(GL_CLIP_DISTANCE0);
}

void Dome::buildMask(int width, int height) {
  // Directions every 360/256 degrees and to the framebuffer's four corners; for each, a point
  // just inside the circle (2 px) and the point where the direction leaves the framebuffer.
  // Between two neighbouring directions the border is one straight side (a corner is itself a
  // direction), so the quads cover everything outside the circle exactly.
  constexpr int kSegments = 256;
  const double cx = 0.5 * width, cy = 0.5 * height;
  const double inner = std::max(0.0, 0.5 * std::min(width, height) - 2.0);
  std::vector<double> phis;
  for (int j = 0; j < kSegments; ++j)
    phis.push_back(2.0 * std::numbers::pi * j / kSegments);
  for (const double sx : {-1.0, 1.0})
    for (const double sy : {-1.0, 1.0}) {
      const double phi = std::atan2(sy * cy, sx * cx);
      phis.push_back(phi < 0.0 ? phi + 2.0 * std::numbers::pi : phi);
    }
  std::sort(phis.begin(), phis.end());
  phis.push_back(phis.front() + 2.0 * std::numbers::pi);
  std::vector<float> v;
  auto point = [&](double phi, bool outer) {
    const double c = std::cos(phi), s = std::sin(phi);
    const double t = outer ? std::min(std::abs(c) > 1e-12 ? cx / std::abs(c) : 1e300,
                                      std::abs(s) > 1e-12 ? cy / std::abs(s) : 1e300)
                           : inner;
    // Outer points exactly on the border (the corners are exact).
    double x = cx + t * c, y = cy + t * s;
    if (outer) {
      x = std::clamp(x, 0.0, static_cast<double>(width));
      y = std::clamp(y, 0.0, static_cast<double>(height));
    }
    v.insert(v.end(), {static_cast<float>(x), static_cast<float>(y)});
  };
  for (std::size_t j = 0; j + 1 < phis.size(); ++j) {
    const double a = phis[j], b = phis[j + 1];
    if (!(b > a)) continue;
    point(a, false);
    point(a, true);
    point(b, true);
    point(a, false);
    point(b, true);
    point(b, false);
  }
  glBindVertexArray(maskVao_.id());
  glBindBuffer(GL_ARRAY_BUFFER, maskVbo_.id());
  glBufferData(
      GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(v.size() * sizeof(float)), v.data(), GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, 2 * sizeof(float), nullptr);
  glBindVertexArray(0);
  maskVertices_ = static_cast<GLsizei>(v.size() / 2);
  maskW_ = width;
  maskH_ = height;
}

void Dome::endDirect(const GlProgram& nodeProgram) {
  glDisable(GL_CLIP_DISTANCE0);
  if (&nodeProgram == directProgram_) glUniform1i(uFisheye_, 0);
}

void Dome::drawMask(GLuint target, int width, int height) {
  glBindFramebuffer(GL_FRAMEBUFFER, target);
  glViewport(0, 0, width, height);
  if (width != maskW_ || height != maskH_) buildMask(width, height);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_BLEND);
  glUseProgram(maskProgram_.id());
  glUniform2f(uMaskViewport_, static_cast<float>(width), static_cast<float>(height));
  glUniform3f(uMaskCircle_,
              static_cast<float>(0.5 * width),
              static_cast<float>(0.5 * height),
              static_cast<float>(0.5 * std::min(width, height)));
  glBindVertexArray(maskVao_.id());
  glDrawArrays(GL_TRIANGLES, 0, maskVertices_);
  glBindVertexArray(0);
  glEnable(GL_DEPTH_TEST);
}

} // namespace tellus::planet
