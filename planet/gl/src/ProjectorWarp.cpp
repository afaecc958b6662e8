#include "ProjectorWarp.hpp"

#include "GlShader.hpp"
#include "SceneDraw.hpp"
#include "Shaders.hpp"

namespace tellus::planet {
namespace {

GlTexture
makeTexture(GLint format, int width, int height, GLenum layout, GLenum type, const void* data) {
  GlTexture t;
  glBindTexture(GL_TEXTURE_2D, t.id());
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexImage2D(GL_TEXTURE_2D, 0, format, width, height, 0, layout, type, data);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  return t;
}

GlFramebuffer framebufferOf(const GlTexture& colour) {
  GlFramebuffer f;
  glBindFramebuffer(GL_FRAMEBUFFER, f.id());
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, colour.id(), 0);
  return f;
}

} // namespace

std::expected<std::unique_ptr<ProjectorWarp>, std::string>
ProjectorWarp::create(const std::string& glslHeader,
                      int sourceWidth,
                      int sourceHeight,
                      int width,
                      int height,
                      const std::optional<WarpMesh>& mesh,
                      const std::optional<std::vector<float>>& blend) {
  const auto pixels = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  if (blend && blend->size() != pixels)
    return std::unexpected("the blend mask has " + std::to_string(blend->size()) +
                           " weights, the channel " + std::to_string(pixels) + " pixels");
  if (mesh && (mesh->columns < 2 || mesh->rows < 2 ||
               mesh->uv.size() !=
                   static_cast<std::size_t>(mesh->columns) * static_cast<std::size_t>(mesh->rows)))
    return std::unexpected(std::string("the warp mesh needs columns x rows (>= 2 each) points"));
  std::unique_ptr<ProjectorWarp> w(new ProjectorWarp());
  auto program = linkProgram(glslHeader + kShader_projector_warp_vert,
                             glslHeader + kShader_projector_warp_frag,
                             "projector warp shader");
  if (!program) return std::unexpected(program.error());
  w->program_ = std::move(*program);
  const GLuint p = w->program_.id();
  w->uRendered_ = glGetUniformLocation(p, "uRendered");
  w->uMesh_ = glGetUniformLocation(p, "uMesh");
  w->uBlend_ = glGetUniformLocation(p, "uBlend");
  w->uSource_ = glGetUniformLocation(p, "uSource");
  w->uOut_ = glGetUniformLocation(p, "uOut");
  w->uMeshSize_ = glGetUniformLocation(p, "uMeshSize");
  w->uHasBlend_ = glGetUniformLocation(p, "uHasBlend");
  w->uSamples_ = glGetUniformLocation(p, "uSamples");
  w->vao_ = GlVertexArray();
  w->sourceWidth_ = sourceWidth;
  w->sourceHeight_ = sourceHeight;
  w->width_ = width;
  w->height_ = height;
  w->rendered_ =
      makeTexture(GL_RGBA8, sourceWidth, sourceHeight, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
  w->renderedFbo_ = framebufferOf(w->rendered_);
  w->out_ = makeTexture(GL_RGBA8, width, height, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
  w->outFbo_ = framebufferOf(w->out_);
  // The mesh's (u, v) narrowed to float for the upload, rows from the top as given.
  std::vector<float> uv{0.0f, 0.0f};
  if (mesh) {
    uv.clear();
    for (const glm::dvec2& v : mesh->uv) {
      uv.push_back(static_cast<float>(v.x));
      uv.push_back(static_cast<float>(v.y));
    }
    w->meshColumns_ = mesh->columns;
    w->meshRows_ = mesh->rows;
  }
  w->mesh_ = makeTexture(
      GL_RG32F, mesh ? mesh->columns : 1, mesh ? mesh->rows : 1, GL_RG, GL_FLOAT, uv.data());
  const float one = 1.0f;
  w->hasBlend_ = blend.has_value();
  w->blend_ = makeTexture(GL_R32F,
                          blend ? width : 1,
                          blend ? height : 1,
                          GL_RED,
                          GL_FLOAT,
                          blend ? static_cast<const void*>(blend->data()) : &one);
  glBindTexture(GL_TEXTURE_2D, 0);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  if (glGetError() != GL_NO_ERROR)
    return std::unexpected(std::string("OpenGL error while setting up the projector warp"));
  return w;
}

void ProjectorWarp::apply(GLuint sceneFbo) {
  glBindFramebuffer(GL_READ_FRAMEBUFFER, sceneFbo);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, renderedFbo_.id());
  glBlitFramebuffer(0,
                    0,
                    sourceWidth_,
                    sourceHeight_,
                    0,
                    0,
                    sourceWidth_,
                    sourceHeight_,
                    GL_COLOR_BUFFER_BIT,
                    GL_NEAREST);
  glBindFramebuffer(GL_FRAMEBUFFER, outFbo_.id());
  GLint viewport[4] = {0, 0, 0, 0};
  glGetIntegerv(GL_VIEWPORT, viewport);
  glViewport(0, 0, width_, height_);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);
  glUseProgram(program_.id());
  const GLuint textures[3] = {rendered_.id(), mesh_.id(), blend_.id()};
  const GLint units[3] = {uRendered_, uMesh_, uBlend_};
  for (GLuint i = 0; i < 3; ++i) {
    glActiveTexture(GL_TEXTURE0 + i);
    glBindTexture(GL_TEXTURE_2D, textures[i]);
    glUniform1i(units[i], static_cast<GLint>(i));
  }
  glUniform2i(uSource_, sourceWidth_, sourceHeight_);
  glUniform2i(uOut_, width_, height_);
  glUniform2i(uMeshSize_, meshColumns_, meshRows_);
  glUniform1i(uHasBlend_, hasBlend_ ? 1 : 0);
  glUniform1i(uSamples_, warpSubsamples(sourceWidth_, sourceHeight_, width_, height_));
  glBindVertexArray(vao_.id());
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glBindVertexArray(0);
  glActiveTexture(GL_TEXTURE0);
  glEnable(GL_DEPTH_TEST); // as the other passes leave it
  glViewport(viewport[0], viewport[1], viewport[2], viewport[3]);
  glBindFramebuffer(GL_FRAMEBUFFER, sceneFbo);
}

std::vector<std::uint8_t> ProjectorWarp::readPixels() const {
  return readFramebufferTopDown(outFbo_.id(), width_, height_);
}

} // namespace tellus::planet
