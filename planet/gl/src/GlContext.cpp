#include "GlContext.hpp"

#include <epoxy/gl.h>
// epoxy first: GLFW must not include a GL header of its own.
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <chrono>
#include <cstdlib>
#include <mutex>
#include <thread>

namespace tellus::planet {

namespace {

// GLFW is process-global: initialised by the first context, terminated by the last.
std::mutex glfwMutex;
int glfwUsers = 0;
std::string glfwLastError;

extern "C" void onGlfwError(int code, const char* text) {
  glfwLastError = std::to_string(code) + ": " + (text ? text : "?");
}

bool acquireGlfw(std::string* error) {
  std::lock_guard lock(glfwMutex);
  if (glfwUsers == 0) {
    glfwSetErrorCallback(onGlfwError);
    // An X server without -noreset resets when its last client leaves (glfwTerminate, below),
    // and refuses connections meanwhile: a display opened again at once may fail a few times.
    bool opened = glfwInit() == GLFW_TRUE;
    const char* display = std::getenv("DISPLAY");
    const bool named = display != nullptr && *display != '\0';
    for (int i = 0; !opened && named && i < 20; ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      opened = glfwInit() == GLFW_TRUE;
    }
    if (!opened) {
      *error =
          "cannot open a display for OpenGL (is DISPLAY set? run under xvfb-run): " + glfwLastError;
      return false;
    }
  }
  ++glfwUsers;
  return true;
}

void releaseGlfw() {
  std::lock_guard lock(glfwMutex);
  if (--glfwUsers == 0) glfwTerminate();
}

GlCapabilities queryCapabilities(bool gl45) {
  GlCapabilities c;
  c.gl45 = gl45;
  const int version = epoxy_gl_version();
  c.textureStorage = version >= 42 || epoxy_has_gl_extension("GL_ARB_texture_storage");
  c.clipControl = version >= 45 || epoxy_has_gl_extension("GL_ARB_clip_control");
  if (version >= 46 || epoxy_has_gl_extension("GL_EXT_texture_filter_anisotropic") ||
      epoxy_has_gl_extension("GL_ARB_texture_filter_anisotropic")) {
    GLfloat most = 1.0f;
    glGetFloatv(GL_MAX_TEXTURE_MAX_ANISOTROPY_EXT, &most);
    c.maxAnisotropy = most;
  }
  c.version = std::string(reinterpret_cast<const char*>(glGetString(GL_VERSION))) + " / " +
              reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  return c;
}

} // namespace

std::expected<std::unique_ptr<GlContext>, std::string>
GlContext::create(const GlContextOptions& options) {
  std::unique_ptr<GlContext> c(new GlContext());
  std::string error;
  if (!acquireGlfw(&error)) return std::unexpected(error);
  c->glfwHeld_ = true;
  // 4.5 core first (glClipControl is core there), then 3.3 core.
  const int versions[2][2] = {{4, 5}, {3, 3}};
  bool gl45 = false;
  for (const auto& v : versions) {
    glfwDefaultWindowHints();
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, v[0]);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, v[1]);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
    glfwWindowHint(GLFW_VISIBLE, options.visible ? GLFW_TRUE : GLFW_FALSE);
    const int ww = options.visible ? options.width : 16, wh = options.visible ? options.height : 16;
    c->window_ = glfwCreateWindow(ww, wh, options.title.c_str(), nullptr, nullptr);
    if (c->window_ != nullptr) {
      gl45 = v[0] == 4;
      break;
    }
  }
  if (c->window_ == nullptr)
    return std::unexpected("cannot create an OpenGL 4.5 or 3.3 core context: " + glfwLastError);
  glfwMakeContextCurrent(c->window_);
  glfwSwapInterval(options.visible && options.vsync ? 1 : 0);
  c->caps_ = queryCapabilities(gl45);
  return c;
}

GlContext::~GlContext() {
  if (window_ != nullptr) glfwDestroyWindow(window_);
  if (glfwHeld_) releaseGlfw();
}

void GlContext::makeCurrent() const {
  glfwMakeContextCurrent(window_);
}

} // namespace tellus::planet
