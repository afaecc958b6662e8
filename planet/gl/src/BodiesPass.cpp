#include "BodiesPass.hpp"

#include "Dome.hpp"
#include "GlShader.hpp"
#include "NodeTextures.hpp"
#include "Shaders.hpp"

#include <tellus/planet/Culling.hpp>
#include <tellus/planet/StarCatalogue.hpp>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace tellus::planet {

namespace {
constexpr double kDegree = std::numbers::pi / 180.0;
} // namespace

std::expected<std::unique_ptr<BodiesPass>, std::string>
BodiesPass::create(const GlCapabilities& gl,
                   bool fisheye,
                   astro::EphemerisBody frameBody,
                   const std::vector<RendererOptions::SceneBody>& bodies) {
  std::unique_ptr<BodiesPass> p(new BodiesPass());
  p->frameBody_ = frameBody;
  const std::string header = gl.glslHeader();
  const std::string defines = fisheye ? "#define TELLUS_FISHEYE 1\n" : "";
  auto program =
      linkProgram(header + defines + kShader_body_vert, header + kShader_body_frag, "bodies");
  if (!program) return std::unexpected(program.error());
  p->program_ = std::move(*program);
  const GLuint id = p->program_.id();
  p->uViewProj_ = glGetUniformLocation(id, "uViewProj");
  p->uSun_ = glGetUniformLocation(id, "uSun");
  p->uTexture_ = glGetUniformLocation(id, "uTexture");
  glUseProgram(id);
  if (const GLint f = glGetUniformLocation(id, "uFisheye"); f >= 0) glUniform1i(f, 0);
  glUseProgram(0);
  for (const auto& b : bodies) {
    const auto which = sceneBodyOf(b.body);
    if (!which)
      return std::unexpected("body '" + b.body.name +
                             "' has no ephemeris: it cannot share a scene");
    if (*which == frameBody) continue;
    auto d = std::unique_ptr<Drawn>(new Drawn{*which, DistantGlobe(b.body), {}, {}, {}, {}, {}});
    d->texture = makeGlobalTexture(b.globalImage, b.colour);
    d->vao = GlVertexArray();
    d->vbo = GlBuffer();
    d->ibo = GlBuffer();
    glBindVertexArray(d->vao.id());
    glBindBuffer(GL_ARRAY_BUFFER, d->vbo.id());
    glBufferData(GL_ARRAY_BUFFER,
                 static_cast<GLsizeiptr>(d->globe.vertexCount() * 8 * sizeof(float)),
                 nullptr,
                 GL_STREAM_DRAW);
    constexpr GLsizei stride = 8 * sizeof(float);
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, nullptr);
    glEnableVertexAttribArray(1);
    glVertexAttribPointer(
        1, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(3 * sizeof(float)));
    glEnableVertexAttribArray(2);
    glVertexAttribPointer(
        2, 2, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(6 * sizeof(float)));
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, d->ibo.id());
    std::vector<unsigned> all;
    for (std::size_t k = 0; k < d->ranges.size(); ++k) {
      const auto& idx = d->globe.indices(1 << k);
      d->ranges[k] = {all.size(), idx.size()};
      all.insert(all.end(), idx.begin(), idx.end());
    }
    glBufferData(GL_ELEMENT_ARRAY_BUFFER,
                 static_cast<GLsizeiptr>(all.size() * sizeof(unsigned)),
                 all.data(),
                 GL_STATIC_DRAW);
    glBindVertexArray(0);
    glBindBuffer(GL_ARRAY_BUFFER, 0);
    p->bodies_.push_back(std::move(d));
  }
  return p;
}

void BodiesPass::draw(const FrameContext& frame) {
  if (bodies_.empty()) return;
  const double t = frame.timeUnixSeconds.value_or(kJ2000UnixSeconds);
  glUseProgram(program_.id());
  glUniformMatrix4fv(uViewProj_, 1, GL_FALSE, &frame.viewProjection[0][0]);
  const bool lit = frame.sunlight && frame.sun.has_value();
  const Ecef s = frame.sun.value_or(Ecef{0.0, 0.0, 1.0});
  glUniform4f(uSun_,
              static_cast<float>(s.x),
              static_cast<float>(s.y),
              static_cast<float>(s.z),
              lit ? 1.0f : 0.0f);
  glUniform1i(uTexture_, 0);
  if (frame.fisheye != nullptr)
    frame.fisheye->beginDirect(
        program_, frame.camera, frame.framebufferWidth, frame.framebufferHeight);
  glDisable(GL_CULL_FACE);
  glDisable(GL_BLEND);
  glActiveTexture(GL_TEXTURE0);
  const Camera& cam = frame.camera;
  // Pixels per unit of tan(angle) on the axis (perspective), or per radian (fisheye).
  const double focal = cam.isFisheye() ? cam.pixelsPerRadian()
                                       : cam.viewport().height / 2.0 /
                                             std::tan(cam.verticalFovDeg() / 2.0 * kDegree);
  for (const auto& d : bodies_) {
    const BodyPlacement at = placeBody(frameBody_, d->which, t);
    // Out of view: neither its vertices made nor uploaded (the sphere of its largest radius).
    const Body& b = d->globe.body();
    const BoundingSphere sphere{at.centre, std::max({b.radiusA, b.radiusB, b.radiusC})};
    if ((cam.isFisheye() ? classifyCone(cam, sphere) : classify(cam.frustum(), sphere)) ==
        FrustumResult::Outside)
      continue;
    const double dist = glm::length(at.centre - frame.eye);
    const double alpha = std::asin(std::min(1.0, d->globe.body().radiusA / std::max(dist, 1.0)));
    const double radiusPx = focal * (cam.isFisheye() ? alpha : std::tan(std::min(alpha, 1.5)));
    const int stride = d->globe.strideFor(radiusPx);
    std::size_t k = 0;
    while ((1 << (k + 1)) <= stride)
      ++k;
    const auto [first, count] = d->ranges[k];
    // Only the vertices the stride draws are made camera-relative, and only their rows uploaded
    // (a disc a few pixels wide: 9 rows of 129 vertices, not 65).
    d->globe.cameraRelative(at, frame.eye, scratch_, stride);
    glBindVertexArray(d->vao.id());
    glBindBuffer(GL_ARRAY_BUFFER, d->vbo.id());
    const auto upload = [this](std::size_t from, std::size_t floats) {
      glBufferSubData(GL_ARRAY_BUFFER,
                      static_cast<GLintptr>(from * sizeof(float)),
                      static_cast<GLsizeiptr>(floats * sizeof(float)),
                      scratch_.data() + from);
    };
    const std::size_t rowFloats = d->globe.rowLength() * 8;
    if (stride == 1)
      upload(0, scratch_.size());
    else
      for (std::size_t row = 0; row < scratch_.size();
           row += rowFloats * static_cast<std::size_t>(stride))
        upload(row, rowFloats);
    glBindTexture(GL_TEXTURE_2D, d->texture.id());
    glDrawElements(GL_TRIANGLES,
                   static_cast<GLsizei>(count),
                   GL_UNSIGNED_INT,
                   reinterpret_cast<const void*>(first * sizeof(unsigned)));
  }
  glBindVertexArray(0);
  glBindBuffer(GL_ARRAY_BUFFER, 0);
  if (frame.fisheye != nullptr) frame.fisheye->endDirect(program_);
}

} // namespace tellus::planet
