#include "NodeTextures.hpp"

#include "TextureDecoder.hpp"

#include <tellus/planet_gl/Renderer.hpp>

#include <algorithm>
#include <cmath>
#include <utility>

namespace tellus::planet {

int nodeTextureLevels(int width, int height) noexcept {
  return static_cast<int>(std::floor(std::log2(std::max(width, height))) + 1);
}

GlTexture makeNodeTexture(int width, int height, const NodeTextureFormat& format) {
  if (format.values) { // one level of floats, never filtered (planet.frag reads it by texelFetch)
    GlTexture texture;
    glBindTexture(GL_TEXTURE_2D, texture.id());
    if (format.storage)
      glTexStorage2D(GL_TEXTURE_2D, 1, GL_R32F, width, height);
    else
      glTexImage2D(GL_TEXTURE_2D, 0, GL_R32F, width, height, 0, GL_RED, GL_FLOAT, nullptr);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    return texture;
  }
  const auto levels = static_cast<GLsizei>(nodeTextureLevels(width, height));
  GlTexture texture;
  glBindTexture(GL_TEXTURE_2D, texture.id());
  if (format.storage) {
    glTexStorage2D(GL_TEXTURE_2D, levels, GL_RGBA8, width, height);
  } else {
    for (GLint l = 0, w = width, h = height; l < levels; ++l) {
      glTexImage2D(GL_TEXTURE_2D, l, GL_RGBA8, w, h, 0, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
      w = std::max(1, w / 2);
      h = std::max(1, h / 2);
    }
  }
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, levels - 1);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  if (format.anisotropy > 1.0f)
    glTexParameterf(GL_TEXTURE_2D, GL_TEXTURE_MAX_ANISOTROPY_EXT, format.anisotropy);
  return texture;
}

NodeTexture TexturePool::acquire(int width,
                                 int height,
                                 int tileWidth,
                                 int tileHeight,
                                 const NodeTextureFormat& format,
                                 std::size_t* reused) {
  if (width != tileWidth || height != tileHeight) // a polar cap's
    return {makeNodeTexture(width, height, format), true};
  if (!free_.empty()) {
    NodeTexture t{std::move(free_.back()), false};
    free_.pop_back();
    ++*reused;
    return t;
  }
  return {makeNodeTexture(tileWidth, tileHeight, format), false};
}

void TexturePool::release(NodeTexture texture) {
  if (!texture.wide && free_.size() < kMaxFree) free_.push_back(std::move(texture.texture));
  // else it is deleted here
}

GlTexture makeGlobalTexture(const std::filesystem::path& image, std::array<std::uint8_t, 3> flat) {
  MipLevel base;
  if (!image.empty()) {
    if (auto img = readImageFile(image)) {
      base.width = img->width;
      base.height = img->height;
      base.rgba.resize(img->pixels.size());
      const auto stride = static_cast<std::size_t>(img->width) * 4;
      for (int y = 0; y < img->height; ++y) // rows from the south, as GL's
        std::copy_n(img->pixels.data() + static_cast<std::size_t>(y) * stride,
                    stride,
                    base.rgba.data() + static_cast<std::size_t>(img->height - 1 - y) * stride);
    }
  }
  if (base.rgba.empty()) {
    base.width = base.height = 1;
    base.rgba = {flat[0], flat[1], flat[2], 255};
  }
  return makeGlobalTexture(std::move(base));
}

GlTexture makeGlobalTexture(MipLevel base) {
  if (base.rgba.empty()) {
    base.width = base.height = 1;
    base.rgba = {10, 20, 60, 255};
  }
  const auto levels = buildMips(std::move(base));
  GlTexture texture;
  glBindTexture(GL_TEXTURE_2D, texture.id());
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  for (std::size_t l = 0; l < levels.size(); ++l)
    glTexImage2D(GL_TEXTURE_2D,
                 static_cast<GLint>(l),
                 GL_RGBA8,
                 levels[l].width,
                 levels[l].height,
                 0,
                 GL_RGBA,
                 GL_UNSIGNED_BYTE,
                 levels[l].rgba.data());
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, static_cast<GLint>(levels.size() - 1));
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  return texture;
}

} // namespace tellus::planet
