#include "WindowPresenter.hpp"

#include "TextOverlay.hpp"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <algorithm>

namespace tellus::planet {

void WindowPresenter::uploadText(int windowHeight) {
  const int scale = windowHeight >= 900 ? 2 : 1;
  const TextImage t = rasterizeText(text_, scale);
  if (!texture_.created()) {
    texture_ = GlTexture();
    fbo_ = GlFramebuffer();
  }
  glBindTexture(GL_TEXTURE_2D, texture_.id());
  glTexImage2D(
      GL_TEXTURE_2D, 0, GL_RGBA8, t.width, t.height, 0, GL_RGBA, GL_UNSIGNED_BYTE, t.rgba.data());
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_.id());
  glFramebufferTexture2D(
      GL_READ_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, texture_.id(), 0);
  textWidth_ = t.width;
  textHeight_ = t.height;
  uploaded_ = text_;
}

void WindowPresenter::present(GLFWwindow* window, GLuint sceneFbo, int width, int height) {
  int fw = 0, fh = 0;
  glfwGetFramebufferSize(window, &fw, &fh);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, sceneFbo);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, 0);
  glBlitFramebuffer(0, 0, width, height, 0, 0, fw, fh, GL_COLOR_BUFFER_BIT, GL_LINEAR);
  if (!text_.empty()) {
    if (text_ != uploaded_) uploadText(fh);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_.id());
    const int w = std::min(textWidth_, fw), h = std::min(textHeight_, fh);
    glBlitFramebuffer(0, 0, w, h, 0, fh - h, w, fh, GL_COLOR_BUFFER_BIT, GL_NEAREST);
  }
  glfwSwapBuffers(window);
  glBindFramebuffer(GL_FRAMEBUFFER, sceneFbo);
}

} // namespace tellus::planet
