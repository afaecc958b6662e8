#pragma once
/**
 * @file GlObjects.hpp
 * @brief Owning handles of OpenGL objects, in the style of Magnum's GL wrappers: a buffer, a
 * vertex array, a texture, a framebuffer, a renderbuffer, a shader and a program each own one GL
 * name and delete it when they go. No bare GLuint of planet/gl outlives the scope that uses it:
 * what lasts longer than a call is one of these.
 *
 * - Constructing one creates the object (glGen*, glCreate*): the context must be current.
 * - `GlTexture t{NoCreate}` owns nothing (the "not created" state, id() == 0), for members made
 *   later and for moved-from handles; destroying or resetting it calls no GL function, so such
 *   handles may be made, moved and destroyed without a context (GL-free unit tests do).
 * - Move-only. Moving leaves the source not created; move-assignment deletes the object the
 *   target held first (as std::unique_ptr does; Magnum swaps instead).
 * - release() gives the name up without deleting it (the caller owns it then); wrap(id) adopts
 *   a name made elsewhere.
 *
 * Threads: a GL object belongs to the context it was made in, which belongs to the main thread
 * (the thread that created the Renderer). Create, use, move and destroy handles that own an
 * object only there, with that context current: Renderer::Impl's destructor makes it current
 * before its members go, and its context is its first member (destroyed last).
 */

#include <epoxy/gl.h>

#include <utility>

namespace tellus::planet {

/** Tag: a handle that owns no GL object yet (Magnum's NoCreate). */
struct NoCreateT {
  explicit constexpr NoCreateT() = default;
};
inline constexpr NoCreateT NoCreate{};

/** One owned GL name of the kind Kind (a struct with static `GLuint create()` and
 * `void destroy(GLuint)`). */
template <class Kind> class GlHandle {
public:
  /** Creates the object (the context must be current). */
  GlHandle() : id_(Kind::create()) {}
  /** Owns nothing (id() == 0). */
  explicit constexpr GlHandle(NoCreateT) noexcept {}
  /** Adopts a name made elsewhere (0: nothing). */
  [[nodiscard]] static GlHandle wrap(GLuint id) noexcept {
    GlHandle h(NoCreate);
    h.id_ = id;
    return h;
  }
  ~GlHandle() { reset(); }
  GlHandle(const GlHandle&) = delete;
  GlHandle& operator=(const GlHandle&) = delete;
  GlHandle(GlHandle&& other) noexcept : id_(std::exchange(other.id_, 0u)) {}
  GlHandle& operator=(GlHandle&& other) noexcept {
    if (this != &other) {
      reset();
      id_ = std::exchange(other.id_, 0u);
    }
    return *this;
  }

  /** The GL name (0 when not created); valid while this handle owns it. */
  GLuint id() const noexcept { return id_; }
  bool created() const noexcept { return id_ != 0; }
  /** Gives the name up without deleting it: the caller owns it now. */
  [[nodiscard]] GLuint release() noexcept { return std::exchange(id_, 0u); }
  /** Deletes the object now (nothing when not created). */
  void reset() noexcept {
    if (id_ != 0) Kind::destroy(std::exchange(id_, 0u));
  }

private:
  GLuint id_ = 0;
};

namespace glkind {
struct Buffer {
  static GLuint create() {
    GLuint id = 0;
    glGenBuffers(1, &id);
    return id;
  }
  static void destroy(GLuint id) { glDeleteBuffers(1, &id); }
};
struct VertexArray {
  static GLuint create() {
    GLuint id = 0;
    glGenVertexArrays(1, &id);
    return id;
  }
  static void destroy(GLuint id) { glDeleteVertexArrays(1, &id); }
};
struct Texture {
  static GLuint create() {
    GLuint id = 0;
    glGenTextures(1, &id);
    return id;
  }
  static void destroy(GLuint id) { glDeleteTextures(1, &id); }
};
struct Framebuffer {
  static GLuint create() {
    GLuint id = 0;
    glGenFramebuffers(1, &id);
    return id;
  }
  static void destroy(GLuint id) { glDeleteFramebuffers(1, &id); }
};
struct Renderbuffer {
  static GLuint create() {
    GLuint id = 0;
    glGenRenderbuffers(1, &id);
    return id;
  }
  static void destroy(GLuint id) { glDeleteRenderbuffers(1, &id); }
};
struct Program {
  static GLuint create() { return glCreateProgram(); }
  static void destroy(GLuint id) { glDeleteProgram(id); }
};
} // namespace glkind

using GlBuffer = GlHandle<glkind::Buffer>;
using GlVertexArray = GlHandle<glkind::VertexArray>;
using GlTexture = GlHandle<glkind::Texture>;
using GlFramebuffer = GlHandle<glkind::Framebuffer>;
using GlRenderbuffer = GlHandle<glkind::Renderbuffer>;
using GlProgram = GlHandle<glkind::Program>;

/** A shader object: its stage is given when it is made (glCreateShader(type)). */
class GlShader {
public:
  explicit GlShader(GLenum type) : handle_(GlHandle<Kind>::wrap(glCreateShader(type))) {}
  explicit constexpr GlShader(NoCreateT) noexcept {}
  GLuint id() const noexcept { return handle_.id(); }
  bool created() const noexcept { return handle_.created(); }
  [[nodiscard]] GLuint release() noexcept { return handle_.release(); }
  void reset() noexcept { handle_.reset(); }

private:
  struct Kind {
    static GLuint create() { return 0; } // never called: made with a stage above
    static void destroy(GLuint id) { glDeleteShader(id); }
  };
  GlHandle<Kind> handle_{NoCreate};
};

} // namespace tellus::planet
