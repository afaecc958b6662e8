#pragma once
/**
 * @file GlContext.hpp
 * @brief The renderer's OpenGL context: GLFW (process-global: initialised by the first context,
 * terminated by the last), one window (a hidden 16 x 16 one when headless: drawing goes to the
 * framebuffer object of SceneDraw), OpenGL 4.5 core, else 3.3 core (forward compatible), and what
 * that GL offers (GlCapabilities).
 *
 * Threads: a context belongs to the thread that created it (the renderer's main thread); every
 * GL object (GlObjects.hpp) is made, used and deleted there with its context current. Several
 * contexts may exist in one process (tests open several renderers): each call that may touch GL
 * on a renderer makes its context current first.
 */

#include <expected>
#include <memory>
#include <string>

struct GLFWwindow;

namespace tellus::planet {

struct GlContextOptions {
  bool visible = false; ///< a window the user sees, of width x height; else hidden, 16 x 16
  int width = 16;
  int height = 16;
  std::string title = "tellus";
  bool vsync = true; ///< visible: the swap waits for the display's refresh
};

/** What the context's GL offers (queried once, at creation). */
struct GlCapabilities {
  bool gl45 = false;           ///< a 4.5 core context (else 3.3 core)
  bool textureStorage = false; ///< glTexStorage2D (4.2 or ARB_texture_storage)
  bool clipControl = false;    ///< glClipControl (4.5 or ARB_clip_control): reversed Z, Depth.hpp
  /** GL_MAX_TEXTURE_MAX_ANISOTROPY (1 without anisotropic filtering). */
  float maxAnisotropy = 1.0f;
  std::string version; ///< GL_VERSION " / " GL_RENDERER
  /** The first line of every shader of this context. */
  std::string glslHeader() const { return gl45 ? "#version 450 core\n" : "#version 330 core\n"; }
};

class GlContext {
public:
  /** Opens the window and its context and makes it current (swap interval 1 when visible with
   * vsync, else 0). Fails with a message: no display (GLFW), no 4.5 or 3.3 core context. */
  static std::expected<std::unique_ptr<GlContext>, std::string>
  create(const GlContextOptions& options);
  ~GlContext();
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  void makeCurrent() const;
  GLFWwindow* window() const noexcept { return window_; }
  const GlCapabilities& capabilities() const noexcept { return caps_; }

private:
  GlContext() = default;
  bool glfwHeld_ = false;
  GLFWwindow* window_ = nullptr;
  GlCapabilities caps_;
};

} // namespace tellus::planet
