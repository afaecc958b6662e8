#pragma once
/**
 * @file WindowPresenter.hpp
 * @brief Showing a frame in the visible window (`tellus view`): the renderer's framebuffer
 * blitted to the window's, the statistics line (Renderer::setOverlayText, TextOverlay.hpp) blitted
 * over it at the top left, the buffers swapped. Never part of readPixels: the line goes to the
 * window only. Main thread, context current.
 */

#include "GlObjects.hpp"

#include <string>

struct GLFWwindow;

namespace tellus::planet {

class WindowPresenter {
public:
  /** The line drawn over the globe from the next present() on ("": none). */
  void setText(std::string text) { text_ = std::move(text); }
  /** Blits sceneFbo (width x height) to the window scaled to its framebuffer size, the line over
   * it (rasterised again only when it changed), swaps, and binds sceneFbo again. */
  void present(GLFWwindow* window, GLuint sceneFbo, int width, int height);

private:
  void uploadText(int windowHeight);
  std::string text_, uploaded_;
  GlTexture texture_{NoCreate};
  GlFramebuffer fbo_{NoCreate};
  int textWidth_ = 0, textHeight_ = 0;
};

} // namespace tellus::planet
