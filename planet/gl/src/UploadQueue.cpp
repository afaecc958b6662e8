#include "UploadQueue.hpp"

#include <algorithm>
#include <chrono>
#include <climits>
#include <utility>

namespace tellus::planet {

int bandRows(std::size_t bandBytes, std::size_t rowBytes, int rowsLeft) noexcept {
  return std::clamp(static_cast<int>(std::min<std::size_t>(bandBytes / rowBytes,
                                                           static_cast<std::size_t>(INT_MAX))),
                    1,
                    rowsLeft);
}

void UploadQueue::push(DecodedTexture texture) {
  Upload u; // its GL texture is taken when its upload starts (step)
  u.texture = std::move(texture);
  queue_.push_back(std::move(u));
}

void UploadQueue::step(LayerSet& layers,
                       const UploadPacer& pacer,
                       const NodeTextureFormat& format,
                       RenderStats& stats) {
  using Clock = std::chrono::steady_clock;
  const auto begin = Clock::now();
  const auto ms = [&] {
    return std::chrono::duration<double, std::milli>(Clock::now() - begin).count();
  };
  std::size_t sentThisFrame = 0;
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  while (!queue_.empty() && pacer.mayContinue(sentThisFrame, ms())) {
    Upload& u = queue_.front();
    LayerTextures* l = layers.byTag(u.texture.tag);
    if (l == nullptr) { // its layer was swapped out or dropped meanwhile: so is its texture
      queue_.pop_front();
      continue;
    }
    NodeTextureFormat layerFormat = format;
    layerFormat.values = u.texture.values; // R32F, one level (ValueTexture.hpp)
    if (!u.gl.texture.created())
      u.gl = l->pool.acquire(u.texture.levels.front().width,
                             u.texture.levels.front().height,
                             l->texWidth,
                             l->texHeight,
                             layerFormat,
                             &stats.texturesReused);
    const MipLevel& level = u.texture.levels[u.level];
    const auto rowBytes = static_cast<std::size_t>(level.width) * 4;
    const int rows = bandRows(pacer.bandBytes(sentThisFrame), rowBytes, level.height - u.row);
    glBindTexture(GL_TEXTURE_2D, u.gl.texture.id());
    glTexSubImage2D(GL_TEXTURE_2D,
                    static_cast<GLint>(u.level),
                    0,
                    u.row,
                    level.width,
                    rows,
                    u.texture.values ? GL_RED : GL_RGBA,
                    u.texture.values ? GL_FLOAT : GL_UNSIGNED_BYTE,
                    level.rgba.data() + static_cast<std::size_t>(u.row) * rowBytes);
    const std::size_t sent = static_cast<std::size_t>(rows) * rowBytes;
    stats.bytesUploaded += sent;
    sentThisFrame += sent;
    u.row += rows;
    if (u.row < level.height) continue;
    u.row = 0;
    if (++u.level < u.texture.levels.size()) continue;
    // Complete: drawable from the next frame on.
    u.gl.sample = std::move(u.texture.sample);
    if (u.texture.values) { // kept for the value under the cursor (ValueTexture.hpp)
      u.gl.width = u.texture.levels.front().width;
      u.gl.height = u.texture.levels.front().height;
      u.gl.values = std::move(u.texture.levels.front().rgba);
    }
    l->install(u.texture.key, std::move(u.gl), u.texture.bytes);
    ++stats.texturesUploaded;
    queue_.pop_front();
  }
}

} // namespace tellus::planet
