// The GL layer of the planet renderer: see Renderer.hpp and docs/ARCHITECTURE.md ("The planet
// renderer"). Every GL call here runs on the thread that created the Renderer.

#include "HeightDecode.hpp"
#include "Shaders.hpp"
#include "TextOverlay.hpp"
#include "TextureDecoder.hpp"
#include "UploadPacer.hpp"

#include <tellus/planet/HeightStreamer.hpp>
#include <tellus/planet/Patch.hpp>
#include <tellus/planet/Quadtree.hpp>
#include <tellus/planet/Terrain.hpp>
#include <tellus/planet/TextureFallback.hpp>
#include <tellus/planet/TextureLru.hpp>
#include <tellus/planet/TextureStreamer.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <epoxy/gl.h>
// epoxy first: GLFW must not include a GL header of its own.
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstring>
#include <deque>
#include <mutex>
#include <stdexcept>
#include <unordered_map>
#include <unordered_set>
#include <utility>

namespace tellus::planet {

namespace {

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

// GLFW is process-global: initialised by the first renderer, terminated by the last.
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
    if (glfwInit() != GLFW_TRUE) {
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

GLuint compileShader(GLenum type, const std::string& source, std::string* error) {
  const GLuint s = glCreateShader(type);
  const char* text = source.c_str();
  glShaderSource(s, 1, &text, nullptr);
  glCompileShader(s);
  GLint ok = GL_FALSE;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (ok != GL_TRUE) {
    char log[2048] = {};
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    *error = std::string("shader: ") + log;
    glDeleteShader(s);
    return 0;
  }
  return s;
}

struct GpuMesh {
  GLuint vao = 0;
  GLuint vbo = 0;
  GLuint ebo = 0;
  std::array<std::uint32_t, 5> quadrantStart{};
  std::size_t zeroAreaTriangles = 0;
  std::array<EdgeAdapt, 4> edges{};
  std::uint64_t heightGeneration = 0;
  std::uint64_t lastUsed = 0;
  bool fixed = false; ///< some side adapted
  /** The n vertices along each side (Direction order) as drawn: what finer neighbours adapt to. */
  std::array<std::vector<glm::dvec3>, 4> sideVertices;
};

/** A double as two floats (high + low): the GPU subtracts the eye's pair, so positions reach the
 * shader relative to the camera without a float ever holding an Earth-sized coordinate, and two
 * nodes that hold the same point draw it at the same place bit for bit (no per-node matrix). */
void splitDouble(double v, float& hi, float& lo) {
  hi = static_cast<float>(v);
  lo = static_cast<float>(v - static_cast<double>(hi));
}

struct Upload {
  DecodedTexture texture;
  GLuint id = 0;
  std::size_t level = 0;
  int row = 0;
};

struct StoredTile {
  std::vector<std::byte> bytes;
  std::uint64_t frame = 0;
};

/** What one draw call draws: a range of a drawn node's triangles (all of it, or the quarter or
 * half under one child whose texture it shows) with a texture through a uv transform of the
 * node's own texture coordinates. */
struct DrawPart {
  const Node* node;
  GLuint texture;
  UvTransform uv;
  int firstQuadrant = 0; ///< quadrant ranges [first, last) of GpuMesh::quadrantStart
  int lastQuadrant = 4;
};

/** The part of `node` under `region` (the node itself or one of its children): which quadrant
 * ranges, and the uv transform for the node's coordinates given the one for region's. */
DrawPart
partFor(const Node& node, const Node& region, GLuint texture, const UvTransform& regionUv) {
  DrawPart d{&node, texture, regionUv, 0, 4};
  if (&region == &node) return d;
  const Sector& s = node.sector();
  const Sector& c = region.sector();
  const double w = s.east - s.west, h = s.north - s.south;
  const glm::dvec2 k{w / (c.east - c.west), h / (c.north - c.south)};
  const glm::dvec2 o{(c.west - s.west) / w, (c.south - s.south) / h};
  // uvRegion = (uvNode - o) * k, then the region's transform.
  d.uv.scale = k * regionUv.scale;
  d.uv.offset = regionUv.offset - o * k * regionUv.scale;
  const bool south = c.south == s.south;
  const bool fullWidth = c.west == s.west && c.east == s.east;
  if (fullWidth) {
    d.firstQuadrant = south ? 0 : 2;
    d.lastQuadrant = d.firstQuadrant + 2;
  } else {
    d.firstQuadrant = (south ? 0 : 2) + (c.west == s.west ? 0 : 1);
    d.lastQuadrant = d.firstQuadrant + 1;
  }
  return d;
}

} // namespace

struct Renderer::Impl {
  Impl(ITileSource& s, const Geodesy& g, RendererOptions o, TileGrid gr)
      : source(s), geodesy(g), opt(std::move(o)), grid(gr), lru(opt.textureBudgetBytes),
        decoder(opt.decodeThreads, opt.decodeNice),
        pacer(UploadPacing{.bytesPerFrame = opt.uploadBytesPerFrame,
                           .shareOfFrame = opt.uploadShareOfFrame}) {}
  ~Impl();

  ITileSource& source;
  const Geodesy& geodesy;
  RendererOptions opt;
  TileGrid grid;
  bool glfwHeld = false;
  GLFWwindow* window = nullptr;
  bool gl45 = false;
  bool textureStorage = false;
  GLuint fbo = 0, colorRb = 0, depthRb = 0;
  GLuint program = 0;
  GLint uViewProj = -1, uEye = -1, uEyeHigh = -1, uEyeLow = -1, uUv = -1, uTexture = -1, uSun = -1;
  bool fp64 = false; ///< vertex positions as doubles (GL 4.x), else high/low float pairs
  GLuint globalTexture = 0;
  int texWidth = 0, texHeight = 0;
  GLsizei texLevels = 1;
  float anisotropy = 1.0f; ///< what the GL allows of opt.anisotropy

  std::unique_ptr<Quadtree> tree;
  std::unique_ptr<HeightField> field; // null without an elevation layer
  std::unique_ptr<HeightStreamer> heights;
  std::vector<TileKey> heightWish;
  std::vector<const Node*> byLevel;
  std::unique_ptr<TextureStreamer> streamer;
  TextureLru lru;
  TextureDecoder decoder;
  UploadPacer pacer;
  std::unordered_map<NodeKey, GpuMesh, NodeKeyHash> meshes;
  std::unordered_map<NodeKey, GLuint, NodeKeyHash> textures;
  std::vector<GLuint> pool;
  std::unordered_map<TileKey, StoredTile, TileKeyHash> received;
  std::unordered_set<NodeKey, NodeKeyHash> decoding;
  std::unordered_set<NodeKey, NodeKeyHash> uploading;
  std::unordered_set<NodeKey, NodeKeyHash> undecodable;
  std::deque<Upload> uploads;
  std::vector<DrawPart> parts;
  RenderStats stats;
  bool lastComplete = false;
  Clock::time_point start = Clock::now();
  // The window's statistics line (setOverlayText): a texture + framebuffer blitted over the
  // globe in the window only (never into the image readPixels returns).
  std::string overlayText, overlayUploaded;
  GLuint overlayTexture = 0, overlayFbo = 0;
  int overlayW = 0, overlayH = 0;

  std::string initGl();
  void makeFramebuffer();
  void freeFramebuffer();
  GLuint newNodeTexture();
  GLuint acquireTexture();
  void releaseTexture(GLuint id);
  const GpuMesh& meshFor(const Node& node);
  double heightAt(double lat, double lon) const {
    return field ? field->heightAt(lat, lon) * opt.verticalExaggeration : 0.0;
  }
  std::array<EdgeAdapt, 4> edgesOf(const Node& node) const;
  double surfaceHeightAt(double lat, double lon) const;
  CameraPose drawnPose{};
  void updateTerrain(double nowS);
  void deliverHeights();
  bool heightsComplete(const Node& node) const;
  void launchDecode(Node& node);
  void stepUploads();
  void evict();
  void draw(const Camera& camera, bool present = true);
  void warmUp();
};

Renderer::Impl::~Impl() {
  if (window != nullptr) {
    glfwMakeContextCurrent(window);
    for (auto& [k, m] : meshes) {
      glDeleteVertexArrays(1, &m.vao);
      glDeleteBuffers(1, &m.vbo);
      glDeleteBuffers(1, &m.ebo);
    }
    for (auto& [k, t] : textures)
      glDeleteTextures(1, &t);
    for (auto& u : uploads)
      glDeleteTextures(1, &u.id);
    if (!pool.empty()) glDeleteTextures(static_cast<GLsizei>(pool.size()), pool.data());
    glDeleteTextures(1, &globalTexture);
    if (overlayFbo != 0) glDeleteFramebuffers(1, &overlayFbo);
    if (overlayTexture != 0) glDeleteTextures(1, &overlayTexture);
    glDeleteProgram(program);
    freeFramebuffer();
    glfwDestroyWindow(window);
  }
  if (glfwHeld) releaseGlfw();
}

std::string Renderer::Impl::initGl() {
  std::string error;
  if (!acquireGlfw(&error)) return error;
  glfwHeld = true;
  // 4.5 core first (glClipControl is core there), then 3.3 core.
  const int versions[2][2] = {{4, 5}, {3, 3}};
  for (const auto& v : versions) {
    glfwDefaultWindowHints();
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, v[0]);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, v[1]);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
    glfwWindowHint(GLFW_VISIBLE, opt.visibleWindow ? GLFW_TRUE : GLFW_FALSE);
    const int ww = opt.visibleWindow ? opt.width : 16, wh = opt.visibleWindow ? opt.height : 16;
    window = glfwCreateWindow(ww, wh, opt.windowTitle.c_str(), nullptr, nullptr);
    if (window != nullptr) {
      gl45 = v[0] == 4;
      break;
    }
  }
  if (window == nullptr) return "cannot create an OpenGL 4.5 or 3.3 core context: " + glfwLastError;
  glfwMakeContextCurrent(window);
  glfwSwapInterval(opt.visibleWindow ? 1 : 0);
  const int version = epoxy_gl_version();
  textureStorage = version >= 42 || epoxy_has_gl_extension("GL_ARB_texture_storage");
  stats.reversedZ = version >= 45 || epoxy_has_gl_extension("GL_ARB_clip_control");
  if (opt.anisotropy > 1.0 &&
      (version >= 46 || epoxy_has_gl_extension("GL_EXT_texture_filter_anisotropic") ||
       epoxy_has_gl_extension("GL_ARB_texture_filter_anisotropic"))) {
    GLfloat most = 1.0f;
    glGetFloatv(GL_MAX_TEXTURE_MAX_ANISOTROPY_EXT, &most);
    anisotropy = std::min(static_cast<float>(opt.anisotropy), most);
  }
  stats.glVersion = std::string(reinterpret_cast<const char*>(glGetString(GL_VERSION))) + " / " +
                    reinterpret_cast<const char*>(glGetString(GL_RENDERER));

  // Shaders (embedded at build time from shaders/).
  const std::string header = gl45 ? "#version 450 core\n" : "#version 330 core\n";
  // Double vertex positions where the GL has them (4.0+: ARB_gpu_shader_fp64; 64-bit vertex
  // attributes are core from 4.1), else the two-float path.
  fp64 = gl45 && opt.fp64Vertices;
  const std::string defines = fp64 ? "#define TELLUS_FP64 1\n" : "";
  const GLuint vs = compileShader(GL_VERTEX_SHADER, header + defines + kShader_planet_vert, &error);
  if (vs == 0) return error;
  const GLuint fs = compileShader(GL_FRAGMENT_SHADER, header + kShader_planet_frag, &error);
  if (fs == 0) {
    glDeleteShader(vs);
    return error;
  }
  program = glCreateProgram();
  glAttachShader(program, vs);
  glAttachShader(program, fs);
  glLinkProgram(program);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint linked = GL_FALSE;
  glGetProgramiv(program, GL_LINK_STATUS, &linked);
  if (linked != GL_TRUE) {
    char log[2048] = {};
    glGetProgramInfoLog(program, sizeof log, nullptr, log);
    return std::string("shader link: ") + log;
  }
  uViewProj = glGetUniformLocation(program, "uViewProj");
  uEye = glGetUniformLocation(program, "uEye");
  uEyeHigh = glGetUniformLocation(program, "uEyeHigh");
  uEyeLow = glGetUniformLocation(program, "uEyeLow");
  uUv = glGetUniformLocation(program, "uUv");
  uTexture = glGetUniformLocation(program, "uTexture");
  uSun = glGetUniformLocation(program, "uSun");

  makeFramebuffer();

  // The global texture: always resident, the last fallback.
  MipLevel base;
  if (!opt.globalImage.empty()) {
    if (auto img = readImageFile(opt.globalImage)) {
      base.width = img->width;
      base.height = img->height;
      base.rgba.resize(img->pixels.size());
      const auto stride = static_cast<std::size_t>(img->width) * 4;
      for (int y = 0; y < img->height; ++y)
        std::copy_n(img->pixels.data() + static_cast<std::size_t>(y) * stride,
                    stride,
                    base.rgba.data() + static_cast<std::size_t>(img->height - 1 - y) * stride);
    }
  }
  if (base.rgba.empty()) {
    base.width = base.height = 1;
    base.rgba = {10, 20, 60, 255};
  }
  const auto levels = buildMips(std::move(base));
  glGenTextures(1, &globalTexture);
  glBindTexture(GL_TEXTURE_2D, globalTexture);
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
  if (glGetError() != GL_NO_ERROR) return "OpenGL error while setting up";
  return {};
}

void Renderer::Impl::makeFramebuffer() {
  glGenFramebuffers(1, &fbo);
  glGenRenderbuffers(1, &colorRb);
  glGenRenderbuffers(1, &depthRb);
  glBindRenderbuffer(GL_RENDERBUFFER, colorRb);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, opt.width, opt.height);
  // 32-bit float depth with reversed Z: 1 m to 1e9 m in one frustum.
  glBindRenderbuffer(GL_RENDERBUFFER, depthRb);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT32F, opt.width, opt.height);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, colorRb);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depthRb);
}

void Renderer::Impl::freeFramebuffer() {
  glDeleteFramebuffers(1, &fbo);
  glDeleteRenderbuffers(1, &colorRb);
  glDeleteRenderbuffers(1, &depthRb);
  fbo = colorRb = depthRb = 0;
}

GLuint Renderer::Impl::newNodeTexture() {
  GLuint id = 0;
  glGenTextures(1, &id);
  glBindTexture(GL_TEXTURE_2D, id);
  if (textureStorage) {
    glTexStorage2D(GL_TEXTURE_2D, texLevels, GL_RGBA8, texWidth, texHeight);
  } else {
    for (GLint l = 0, w = texWidth, h = texHeight; l < texLevels; ++l) {
      glTexImage2D(GL_TEXTURE_2D, l, GL_RGBA8, w, h, 0, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
      w = std::max(1, w / 2);
      h = std::max(1, h / 2);
    }
  }
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, texLevels - 1);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  if (anisotropy > 1.0f) glTexParameterf(GL_TEXTURE_2D, GL_TEXTURE_MAX_ANISOTROPY_EXT, anisotropy);
  return id;
}

// Every node texture has the grid's tile size, so any freed one fits the next node.
GLuint Renderer::Impl::acquireTexture() {
  if (!pool.empty()) {
    const GLuint id = pool.back();
    pool.pop_back();
    ++stats.texturesReused;
    return id;
  }
  return newNodeTexture();
}

void Renderer::Impl::releaseTexture(GLuint id) {
  constexpr std::size_t kMaxPool = 64;
  if (pool.size() < kMaxPool)
    pool.push_back(id);
  else
    glDeleteTextures(1, &id);
}

// The drawn node across each side whose edge is coarser than ours along it: that side adapts
// (the finer side moves onto the coarser one's chords). Along east/west sides a node's extent is
// its latitude span, along north/south sides its longitude span. The neighbour pointer gives the
// deepest node of our level or coarser whose edge contains ours; when it is not drawn, the drawn
// node across is found among its descendants whose edge still contains ours: near the poles a
// finer node of a merged row can be wider than we are, i.e. coarser along the shared edge.
std::array<EdgeAdapt, 4> Renderer::Impl::edgesOf(const Node& node) const {
  std::array<EdgeAdapt, 4> e{};
  if (!opt.fixEdges) return e;
  const Sector& s = node.sector();
  const std::uint64_t frame = tree->frame();
  for (int d = 0; d < 4; ++d) {
    const auto dir = static_cast<Direction>(d);
    const bool alongLon = dir == Direction::North || dir == Direction::South;
    const Node* nb = node.neighbour(dir);
    while (nb != nullptr && nb->lastDrawnFrame() != frame) {
      const Node* next = nullptr;
      const Sector& p = nb->sector();
      for (int slot = 0; slot < 4 && next == nullptr; ++slot) {
        const Node* c = nb->child(slot);
        if (c == nullptr) continue;
        const Sector& cs = c->sector();
        const bool facing = dir == Direction::North   ? cs.south == p.south
                            : dir == Direction::South ? cs.north == p.north
                            : dir == Direction::East  ? cs.west == p.west
                                                      : cs.east == p.east;
        const bool contains = alongLon ? cs.west <= s.west && s.east <= cs.east
                                       : cs.south <= s.south && s.north <= cs.north;
        if (facing && contains) next = c;
      }
      nb = next;
    }
    if (nb == nullptr) continue;
    const Sector& o = nb->sector();
    const double mine = alongLon ? s.east - s.west : s.north - s.south;
    const double theirs = alongLon ? o.east - o.west : o.north - o.south;
    if (!(theirs > mine)) continue;
    EdgeAdapt& a = e[static_cast<std::size_t>(d)];
    a.active = true;
    a.coarse = o;
    // Its side facing us, as it draws it (meshes are built coarse first, see frame()).
    const auto opposite = static_cast<std::size_t>((d + 2) % 4);
    if (const auto it = meshes.find(nb->key()); it != meshes.end())
      a.coarseVertices = it->second.sideVertices[opposite];
  }
  return e;
}

const GpuMesh& Renderer::Impl::meshFor(const Node& node) {
  auto [it, inserted] = meshes.try_emplace(node.key());
  GpuMesh& m = it->second;
  m.lastUsed = stats.frames;
  const std::array<EdgeAdapt, 4> edges = edgesOf(node);
  // Stale when heights changed under the node, or under a coarser neighbour its edges follow
  // (whose chord ends may lie beyond this node's edge).
  bool stale = field && field->changedSince(m.heightGeneration, node.sector());
  for (const EdgeAdapt& e : edges)
    stale = stale || (field && e.active && field->changedSince(m.heightGeneration, e.coarse));
  if (!inserted && edges == m.edges && !stale) return m;
  const auto t0 = Clock::now();
  const TerrainMesh mesh = buildTerrainMesh(
      geodesy,
      node.sector(),
      opt.meshSize,
      [this](double lat, double lon) { return heightAt(lat, lon); },
      edges);
  m.edges = edges;
  m.heightGeneration = field ? field->generation() : 0;
  m.quadrantStart = mesh.quadrantStart;
  m.zeroAreaTriangles = mesh.zeroAreaTriangles;
  m.fixed = std::any_of(edges.begin(), edges.end(), [](const EdgeAdapt& a) { return a.active; });
  {
    const int n = opt.meshSize;
    for (int d = 0; d < 4; ++d) {
      auto& side = m.sideVertices[static_cast<std::size_t>(d)];
      side.resize(static_cast<std::size_t>(n));
      for (int i = 0; i < n; ++i) {
        const int r = d == static_cast<int>(Direction::North)   ? n - 1
                      : d == static_cast<int>(Direction::South) ? 0
                                                                : i;
        const int c = d == static_cast<int>(Direction::East)   ? n - 1
                      : d == static_cast<int>(Direction::West) ? 0
                                                               : i;
        side[static_cast<std::size_t>(i)] =
            mesh.vertices[static_cast<std::size_t>(r * n + c)].position;
      }
    }
  }
  std::vector<float> v;
  v.reserve(mesh.vertices.size() * 11);
  // 44 bytes a vertex either way: the position as three doubles (fp64) or as high and low floats,
  // then the normal and the node uv as floats.
  for (const TerrainVertex& p : mesh.vertices) {
    float pos[6];
    if (fp64) {
      std::memcpy(pos, &p.position[0], sizeof(double));
      std::memcpy(pos + 2, &p.position[1], sizeof(double));
      std::memcpy(pos + 4, &p.position[2], sizeof(double));
    } else {
      for (int i = 0; i < 3; ++i)
        splitDouble(p.position[i], pos[i], pos[3 + i]);
    }
    v.insert(v.end(),
             {pos[0],
              pos[1],
              pos[2],
              pos[3],
              pos[4],
              pos[5],
              p.normal.x,
              p.normal.y,
              p.normal.z,
              static_cast<float>(p.uvNode.x),
              static_cast<float>(p.uvNode.y)});
  }
  if (m.vao == 0) {
    glGenVertexArrays(1, &m.vao);
    glGenBuffers(1, &m.vbo);
    glGenBuffers(1, &m.ebo);
  }
  glBindVertexArray(m.vao);
  glBindBuffer(GL_ARRAY_BUFFER, m.vbo);
  glBufferData(
      GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(v.size() * sizeof(float)), v.data(), GL_STATIC_DRAW);
  constexpr GLsizei stride = 11 * sizeof(float);
  const auto at = [](std::size_t floats) {
    return reinterpret_cast<const void*>(floats * sizeof(float));
  };
  glEnableVertexAttribArray(0);
  if (fp64) {
    glVertexAttribLPointer(0, 3, GL_DOUBLE, stride, at(0));
    glDisableVertexAttribArray(1);
  } else {
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, at(0));
    glEnableVertexAttribArray(1);
    glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, stride, at(3));
  }
  glEnableVertexAttribArray(2);
  glVertexAttribPointer(2, 3, GL_FLOAT, GL_FALSE, stride, at(6));
  glEnableVertexAttribArray(3);
  glVertexAttribPointer(3, 2, GL_FLOAT, GL_FALSE, stride, at(9));
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, m.ebo);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER,
               static_cast<GLsizeiptr>(mesh.indices.size() * sizeof(std::uint32_t)),
               mesh.indices.data(),
               GL_STATIC_DRAW);
  glBindVertexArray(0);
  ++stats.meshesBuilt;
  ++stats.meshesBuiltLast;
  const double ms = msSince(t0);
  stats.meshMs += ms;
  stats.meshMsTotal += ms;
  return m;
}

// Heights for the drawn nodes: each needs the elevation level whose samples are as fine as its
// grid (one heightmap serves several node levels, thesis 4.5.1), coarse levels first. A few
// arrivals per frame go into the field, and the meshes they change are rebuilt in the same frame
// (meshFor), so every frame's meshes come from one state of the heights.
void Renderer::Impl::updateTerrain(double nowS) {
  if (!field) return;
  heightWish.clear();
  const int n = opt.meshSize;
  for (const Node* node : tree->drawList()) {
    const Sector& s = node->sector();
    const int level = field->levelForSpacing((s.north - s.south) / (n - 1));
    for (int l = 0; l <= level; l = l == level ? level + 1 : std::min(level, l + 3)) {
      const auto keys = field->grid().keysCovering(s, l, 16);
      if (keys) heightWish.insert(heightWish.end(), keys->begin(), keys->end());
    }
  }
  std::stable_sort(heightWish.begin(), heightWish.end(), [](const TileKey& a, const TileKey& b) {
    return a.level < b.level;
  });
  heightWish.erase(std::unique(heightWish.begin(), heightWish.end()), heightWish.end());
  {
    std::unordered_set<TileKey, TileKeyHash> seen;
    std::erase_if(heightWish, [&](const TileKey& k) { return !seen.insert(k).second; });
  }
  heights->want(heightWish, *field, nowS);
  const HeightStreamStats& hs = heights->stats();
  stats.heightTilesRequested = hs.requested;
  stats.heightTilesReceived = hs.received;
  stats.heightTilesAbsent = hs.absent;
  stats.heightTilesFailed = hs.failed + hs.decodeErrors;
}

// A few decoded height tiles into the field, at the start of a frame: the camera is kept above the
// surface they make, and the meshes they change are rebuilt before this frame draws.
void Renderer::Impl::deliverHeights() {
  if (!field) return;
  const std::uint64_t before = field->generation();
  if (heights->deliver(*field, 8) > 0) {
    tree->refreshHeights([&](const Sector& sec) { return field->changedSince(before, sec); });
    tree->setTerrain(
        [this](const Sector& sec) {
          const auto [lo, hi] = field->rangeOver(sec);
          return std::pair{lo * opt.verticalExaggeration, hi * opt.verticalExaggeration};
        },
        std::min(0.0, field->lowest() * opt.verticalExaggeration) - 1000.0);
  }
}

bool Renderer::Impl::heightsComplete(const Node& node) const {
  if (!field) return true;
  const Sector& s = node.sector();
  const int level = field->levelForSpacing((s.north - s.south) / (opt.meshSize - 1));
  const auto keys = field->grid().keysCovering(s, level, 16);
  if (!keys) return true;
  return std::all_of(
      keys->begin(), keys->end(), [&](const TileKey& k) { return heights->settled(k, *field); });
}

// A node whose tiles all arrived (TextureState::Decoding): its bytes go to a decoder worker.
void Renderer::Impl::launchDecode(Node& node) {
  const NodeKey& k = node.key();
  if (uploading.contains(k)) {
    node.texture = TextureState::Uploading;
    return;
  }
  if (node.texture != TextureState::Decoding || decoding.contains(k) || undecodable.contains(k))
    return;
  if (lru.resident(k)) return;
  bool missing = false;
  for (std::int64_t i = 0; i < textureTileCount(k); ++i) {
    const TileKey t = textureTile(k, i);
    if (streamer->state(t) != TileFetch::Absent && !received.contains(t)) {
      // Its bytes went into an earlier texture that was since evicted: ask again.
      streamer->forget({t.level, t.row, t.col, 1});
      missing = true;
    }
  }
  if (missing) return;
  DecodeJob job;
  job.key = k;
  job.width = texWidth;
  job.height = texHeight;
  for (std::int64_t i = 0; i < textureTileCount(k); ++i) {
    const auto it = received.find(textureTile(k, i));
    if (it == received.end()) {
      job.tiles.emplace_back(std::nullopt);
    } else {
      job.tiles.emplace_back(std::move(it->second.bytes));
      received.erase(it);
    }
  }
  decoding.insert(k);
  decoder.submit(std::move(job));
}

// Row bands of one mip level at a time, within the frame's byte and time caps (UploadPacer). A
// texture is taken from the pool or made when its first band goes, so that making many textures
// is spread over frames like their bytes. The texture is not in the LRU (its node is Uploading,
// never Finished) until every level is there, so no frame samples a half-uploaded level.
void Renderer::Impl::stepUploads() {
  const auto begin = Clock::now();
  std::size_t sentThisFrame = 0;
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  while (!uploads.empty() && pacer.mayContinue(sentThisFrame, msSince(begin))) {
    Upload& u = uploads.front();
    if (u.id == 0) u.id = acquireTexture();
    const MipLevel& level = u.texture.levels[u.level];
    const auto rowBytes = static_cast<std::size_t>(level.width) * 4;
    const auto band = pacer.bandBytes(sentThisFrame);
    const int rows = std::clamp(
        static_cast<int>(std::min<std::size_t>(band / rowBytes, static_cast<std::size_t>(INT_MAX))),
        1,
        level.height - u.row);
    glBindTexture(GL_TEXTURE_2D, u.id);
    glTexSubImage2D(GL_TEXTURE_2D,
                    static_cast<GLint>(u.level),
                    0,
                    u.row,
                    level.width,
                    rows,
                    GL_RGBA,
                    GL_UNSIGNED_BYTE,
                    level.rgba.data() + static_cast<std::size_t>(u.row) * rowBytes);
    const std::size_t sent = static_cast<std::size_t>(rows) * rowBytes;
    stats.bytesUploaded += sent;
    sentThisFrame += sent;
    u.row += rows;
    if (u.row < level.height) continue;
    u.row = 0;
    if (++u.level < u.texture.levels.size()) continue;
    // Complete: drawable from the next frame on.
    const NodeKey key = u.texture.key;
    if (auto old = textures.find(key); old != textures.end()) releaseTexture(old->second);
    textures[key] = u.id;
    lru.insert(key, u.texture.bytes);
    uploading.erase(key);
    ++stats.texturesUploaded;
    uploads.pop_front();
  }
}

// Textures the LRU let go: back to the pool, their tiles may be fetched again, and any node still
// marked Finished for them falls back from now on.
void Renderer::Impl::evict() {
  const auto evicted = lru.takeEvicted();
  if (evicted.empty()) return;
  std::unordered_set<NodeKey, NodeKeyHash> gone;
  for (const NodeKey& k : evicted) {
    if (auto it = textures.find(k); it != textures.end()) {
      releaseTexture(it->second);
      textures.erase(it);
    }
    streamer->forget(k);
    gone.insert(k);
    ++stats.texturesEvicted;
  }
  tree->forEach([&](Node& n) {
    if (n.texture == TextureState::Finished && gone.contains(n.key()))
      n.texture = TextureState::NoTexture;
  });
}

void Renderer::Impl::draw(const Camera& camera, bool present) {
  glBindFramebuffer(GL_FRAMEBUFFER, fbo);
  glViewport(0, 0, opt.width, opt.height);
  if (stats.reversedZ) glClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE);
  glClearColor(static_cast<float>(opt.background[0]),
               static_cast<float>(opt.background[1]),
               static_cast<float>(opt.background[2]),
               1.0f);
  glClearDepth(0.0);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_GREATER);
  glDisable(GL_CULL_FACE);
  glUseProgram(program);
  glUniform1i(uTexture, 0);
  glActiveTexture(GL_TEXTURE0);
  // One view-projection for every node, rotation only (the eye at the origin), narrowed to float
  // here; positions arrive as high/low float pairs and the shader subtracts the eye's pair.
  glm::dmat4 view = camera.view();
  view[3] = glm::dvec4(0.0, 0.0, 0.0, 1.0);
  const glm::mat4 viewProj(camera.projection() * view);
  glUniformMatrix4fv(uViewProj, 1, GL_FALSE, &viewProj[0][0]);
  if (fp64) {
    glUniform3d(uEye, camera.position().x, camera.position().y, camera.position().z);
  } else {
    float eh[3], el[3];
    for (int i = 0; i < 3; ++i)
      splitDouble(camera.position()[i], eh[i], el[i]);
    glUniform3f(uEyeHigh, eh[0], eh[1], eh[2]);
    glUniform3f(uEyeLow, el[0], el[1], el[2]);
  }
  if (opt.sunLatLon) {
    const Ecef sun = geodesy.surfaceNormal((*opt.sunLatLon)[0], (*opt.sunLatLon)[1]);
    glUniform4f(uSun,
                static_cast<float>(sun.x),
                static_cast<float>(sun.y),
                static_cast<float>(sun.z),
                1.0f);
  } else {
    glUniform4f(uSun, 0.0f, 0.0f, 0.0f, 0.0f);
  }
  for (const DrawPart& p : parts) {
    const GpuMesh& m = meshFor(*p.node);
    glUniform4f(uUv,
                static_cast<float>(p.uv.scale.x),
                static_cast<float>(p.uv.scale.y),
                static_cast<float>(p.uv.offset.x),
                static_cast<float>(p.uv.offset.y));
    glBindTexture(GL_TEXTURE_2D, p.texture);
    glBindVertexArray(m.vao);
    const std::uint32_t first = m.quadrantStart[static_cast<std::size_t>(p.firstQuadrant)];
    const std::uint32_t last = m.quadrantStart[static_cast<std::size_t>(p.lastQuadrant)];
    glDrawElements(
        GL_TRIANGLES,
        static_cast<GLsizei>(last - first),
        GL_UNSIGNED_INT,
        reinterpret_cast<const void*>(static_cast<std::uintptr_t>(first) * sizeof(std::uint32_t)));
  }
  glBindVertexArray(0);
  if (present && window != nullptr && opt.visibleWindow) {
    int fw = 0, fh = 0;
    glfwGetFramebufferSize(window, &fw, &fh);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo);
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, 0);
    glBlitFramebuffer(0, 0, opt.width, opt.height, 0, 0, fw, fh, GL_COLOR_BUFFER_BIT, GL_LINEAR);
    if (!overlayText.empty()) {
      if (overlayText != overlayUploaded) {
        const int scale = fh >= 900 ? 2 : 1;
        const TextImage t = rasterizeText(overlayText, scale);
        if (overlayTexture == 0) {
          glGenTextures(1, &overlayTexture);
          glGenFramebuffers(1, &overlayFbo);
        }
        glBindTexture(GL_TEXTURE_2D, overlayTexture);
        glTexImage2D(GL_TEXTURE_2D,
                     0,
                     GL_RGBA8,
                     t.width,
                     t.height,
                     0,
                     GL_RGBA,
                     GL_UNSIGNED_BYTE,
                     t.rgba.data());
        glBindFramebuffer(GL_READ_FRAMEBUFFER, overlayFbo);
        glFramebufferTexture2D(
            GL_READ_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, overlayTexture, 0);
        overlayW = t.width;
        overlayH = t.height;
        overlayUploaded = overlayText;
      }
      glBindFramebuffer(GL_READ_FRAMEBUFFER, overlayFbo);
      const int w = std::min(overlayW, fw), h = std::min(overlayH, fh);
      glBlitFramebuffer(0, 0, w, h, 0, fh - h, w, fh, GL_COLOR_BUFFER_BIT, GL_NEAREST);
    }
    glfwSwapBuffers(window);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo);
  }
}

// One untimed frame before the first real one, so that no frame pays for first use: the driver
// compiles the program's variants for both kinds of texture (llvmpipe does so at the first draw,
// 0.3-0.6 s without Mesa's shader cache), and every GL entry point the frame loop calls is resolved
// (libepoxy looks each one up on its first call; with the tile service dlopen()ing its imaging
// module on a worker at the same time, such a lookup waited 0.3-0.9 s for the loader's lock).
// Draws into the framebuffer, which the first frame clears; leaves nothing behind.
void Renderer::Impl::warmUp() {
  const Node* root = nullptr;
  for (const auto& r : tree->roots())
    if (r && root == nullptr) root = r.get();
  if (root == nullptr) return;
  const RenderStats before = stats; // the warm-up counts no mesh, upload or texture
  const GLuint texture = newNodeTexture();
  const std::uint8_t texel[4] = {0, 0, 0, 255};
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexSubImage2D(GL_TEXTURE_2D, texLevels - 1, 0, 0, 1, 1, GL_RGBA, GL_UNSIGNED_BYTE, texel);
  parts.clear();
  parts.push_back({root, globalTexture, globalUv(root->sector())});
  parts.push_back({root, texture, UvTransform{}});
  const Camera cam(geodesy, CameraPose{}, {opt.width, opt.height}, opt.verticalFovDeg);
  draw(cam, false);
  glFinish();
  parts.clear();
  if (auto it = meshes.find(root->key()); it != meshes.end()) {
    glDeleteVertexArrays(1, &it->second.vao);
    glDeleteBuffers(1, &it->second.vbo);
    glDeleteBuffers(1, &it->second.ebo);
    meshes.erase(it);
  }
  glDeleteTextures(1, &texture);
  stats = before;
}

Renderer::Renderer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

void Renderer::setOverlayText(std::string text) {
  impl_->overlayText = std::move(text);
}
Renderer::~Renderer() = default;

std::expected<std::unique_ptr<Renderer>, std::string>
Renderer::create(ITileSource& source, const Geodesy& geodesy, RendererOptions options) {
  if (options.width <= 0 || options.height <= 0 || options.width > 16384 || options.height > 16384)
    return std::unexpected(std::string("the image size must be 1 to 16384 pixels each way"));
  if (!(options.lodThreshold > 0.0) || !std::isfinite(options.lodThreshold))
    return std::unexpected(std::string("the LOD threshold must be a positive number"));
  const int n = options.meshSize;
  if (n < 3 || n > 1025 || ((n - 1) & (n - 2)) != 0)
    return std::unexpected(std::string("the mesh size must be 2^k + 1 (3 to 1025)"));
  const auto spec = source.describe(options.layer, options.time);
  if (!spec) return std::unexpected("unknown layer '" + options.layer + "'");
  auto grid = TileGrid::create(spec->grid);
  if (!grid) return std::unexpected("layer '" + options.layer + "': " + grid.error());
  auto impl = std::make_unique<Impl>(source, geodesy, std::move(options), *grid);
  impl->texWidth = grid->spec().tileWidth;
  impl->texHeight = grid->spec().tileHeight;
  impl->texLevels =
      static_cast<GLsizei>(std::floor(std::log2(std::max(impl->texWidth, impl->texHeight))) + 1);
  if (auto err = impl->initGl(); !err.empty()) return std::unexpected(err);
  QuadtreeParams qp;
  qp.lod.tileWidthPx = impl->texWidth;
  qp.lod.tileHeightPx = impl->texHeight;
  qp.lod.threshold = impl->opt.lodThreshold;
  qp.maxSplitsPerFrame = impl->opt.maxSplitsPerFrame;
  impl->tree = std::make_unique<Quadtree>(geodesy, *grid, qp);
  StreamParams sp;
  sp.layer = impl->opt.layer;
  sp.time = impl->opt.time;
  sp.maxInFlight = impl->opt.maxInFlight;
  impl->streamer = std::make_unique<TextureStreamer>(source, sp);
  if (!impl->opt.elevationLayer.empty()) {
    if (!(impl->opt.verticalExaggeration > 0.0) || !std::isfinite(impl->opt.verticalExaggeration))
      return std::unexpected(std::string("the vertical exaggeration must be a positive number"));
    const auto espec = source.describe(impl->opt.elevationLayer, impl->opt.elevationTime);
    if (!espec)
      return std::unexpected("unknown elevation layer '" + impl->opt.elevationLayer + "'");
    auto egrid = TileGrid::create(espec->grid);
    if (!egrid)
      return std::unexpected("layer '" + impl->opt.elevationLayer + "': " + egrid.error());
    impl->field = std::make_unique<HeightField>(*egrid);
    HeightStreamParams hp;
    hp.layer = impl->opt.elevationLayer;
    hp.time = impl->opt.elevationTime;
    hp.encoding = impl->opt.elevationEncoding;
    hp.datum = impl->opt.verticalDatum;
    impl->heights = std::make_unique<HeightStreamer>(
        source,
        *egrid,
        hp,
        impl->opt.heightDecoder ? impl->opt.heightDecoder : HeightDecoder(decodeHeights));
    Impl* raw = impl.get();
    impl->tree->setTerrain(
        [raw](const Sector& sec) {
          const auto [lo, hi] = raw->field->rangeOver(sec);
          return std::pair{lo * raw->opt.verticalExaggeration, hi * raw->opt.verticalExaggeration};
        },
        -1000.0);
  }
  impl->warmUp();
  return std::unique_ptr<Renderer>(new Renderer(std::move(impl)));
}

// The height of the surface as drawn, conservatively: the data's height at the point, and the
// heights of the grid cell's corners of the drawn node over it (a coarse node's flat cell can lie
// above the data's valley), including the coarse chord's ends where that side is edge-fixed.
double Renderer::Impl::surfaceHeightAt(double lat, double lon) const {
  double h = heightAt(lat, lon);
  if (!tree || !std::isfinite(h)) return h;
  lon = std::remainder(lon, 360.0);
  const int n = opt.meshSize;
  for (const Node* node : tree->drawList()) {
    const Sector& s = node->sector();
    if (lat < s.south || lat > s.north || lon < s.west || lon > s.east) continue;
    const int r = std::clamp(
        static_cast<int>(std::floor((lat - s.south) / (s.north - s.south) * (n - 1))), 0, n - 2);
    const int c = std::clamp(
        static_cast<int>(std::floor((lon - s.west) / (s.east - s.west) * (n - 1))), 0, n - 2);
    for (int dr = 0; dr < 2; ++dr)
      for (int dc = 0; dc < 2; ++dc)
        h = std::max(
            h,
            heightAt(edgeLerp(s.south, s.north, r + dr, n), edgeLerp(s.west, s.east, c + dc, n)));
    if (const auto it = meshes.find(node->key()); it != meshes.end())
      for (int d = 0; d < 4; ++d) {
        const EdgeAdapt& e = it->second.edges[static_cast<std::size_t>(d)];
        if (!e.active) continue;
        const bool alongLon =
            d == static_cast<int>(Direction::North) || d == static_cast<int>(Direction::South);
        const double a = alongLon ? e.coarse.west : e.coarse.south,
                     b = alongLon ? e.coarse.east : e.coarse.north;
        const double p = alongLon ? lon : lat;
        const int j =
            std::clamp(static_cast<int>(std::floor((p - a) / (b - a) * (n - 1))), 0, n - 2);
        for (int k = 0; k < 2; ++k) {
          const double q = edgeLerp(a, b, j + k, n);
          const double fixedCoord = d == static_cast<int>(Direction::North)   ? s.north
                                    : d == static_cast<int>(Direction::South) ? s.south
                                    : d == static_cast<int>(Direction::East)  ? s.east
                                                                              : s.west;
          h = std::max(h, alongLon ? heightAt(fixedCoord, q) : heightAt(q, fixedCoord));
        }
      }
    break;
  }
  return h;
}

CameraPose Renderer::drawnPose() const {
  return impl_->drawnPose;
}

CameraPose Renderer::clampToTerrain(const CameraPose& pose) const {
  CameraPose p = pose;
  if (!impl_->field || !std::isfinite(pose.latDeg) || !std::isfinite(pose.lonDeg)) return p;
  const double floor =
      impl_->surfaceHeightAt(pose.latDeg, pose.lonDeg) + impl_->opt.terrainClearanceM;
  if (p.altitudeM < floor) p.altitudeM = floor;
  return p;
}

double Renderer::terrainHeight(double latDeg, double lonDeg) const {
  return impl_->heightAt(latDeg, lonDeg);
}

const Geodesy& Renderer::geodesy() const noexcept {
  return impl_->geodesy;
}

Camera Renderer::camera(const CameraPose& pose) const {
  const RendererOptions& o = impl_->opt;
  // A low camera needs a nearer near plane than 0.1 m; its height above the ground below it
  // (the terrain when heights are loaded) decides (docs/ACCURACY.md, numerical stability).
  double above = pose.altitudeM;
  if (std::isfinite(pose.latDeg) && std::isfinite(pose.lonDeg)) {
    const double ground = impl_->heightAt(pose.latDeg, pose.lonDeg);
    if (std::isfinite(ground)) above -= ground;
  }
  const double aspect = static_cast<double>(o.width) / static_cast<double>(o.height);
  return Camera(impl_->geodesy,
                pose,
                {o.width, o.height},
                o.verticalFovDeg,
                nearDistanceFor(above, o.verticalFovDeg, aspect));
}

void Renderer::frame(const CameraPose& pose) {
  Impl& m = *impl_;
  const auto t0 = Clock::now();
  m.deliverHeights();
  CameraPose safe = clampToTerrain(pose);
  m.stats.cameraLifted = safe.altitudeM != pose.altitudeM;
  m.drawnPose = safe;
  Camera cam = camera(safe);
  m.stats.meshesBuiltLast = 0;
  m.stats.meshMs = 0.0;
  if (m.window != nullptr) glfwMakeContextCurrent(m.window);
  ++m.stats.frames;

  // CPU update: the tree and the stream order.
  const FrameStats& fs = m.tree->update(cam);
  m.lru.beginFrame();
  const double nowS = std::chrono::duration<double>(t0 - m.start).count();
  m.streamer->update(*m.tree, cam, nowS, &m.lru);
  m.updateTerrain(nowS);
  m.stats.updateMs = msSince(t0);
  m.stats.longestUpdateMs = std::max(m.stats.longestUpdateMs, m.stats.updateMs);
  FramePhases ph;
  ph.update = m.stats.updateMs;
  auto tPhase = Clock::now();
  auto lap = [&tPhase] {
    const auto now = Clock::now();
    const double ms = std::chrono::duration<double, std::milli>(now - tPhase).count();
    tPhase = now;
    return ms;
  };

  for (ReceivedTile& r : m.streamer->takeReceived()) {
    m.stats.bytesReceived += r.result.bytes.size();
    m.received[r.key] = {std::move(r.result.bytes), m.stats.frames};
  }
  for (const auto& root : m.tree->roots())
    if (root) m.launchDecode(*root);
  for (Node* n : m.tree->drawList())
    m.launchDecode(*n);
  for (DecodedTexture& d : m.decoder.takeDone()) {
    m.decoding.erase(d.key);
    if (!d.ok) {
      ++m.stats.decodeErrors;
      m.undecodable.insert(d.key);
      continue;
    }
    ++m.stats.texturesDecoded;
    if (m.lru.resident(d.key)) continue;
    Upload u; // its texture is taken when its upload starts (stepUploads)
    u.texture = std::move(d);
    m.uploading.insert(u.texture.key);
    m.uploads.push_back(std::move(u));
  }
  ph.intake = lap();

  // What this frame draws, and the LRU told so before anything new is inserted.
  m.parts.clear();
  // The roots stay resident like the global texture: the streamer wants them until they are, so
  // evicting one would only fetch it again (a loop when the budget is small).
  for (const auto& root : m.tree->roots())
    if (root) m.lru.use(root->key());
  bool complete = fs.splitsDeferred == 0;
  m.stats.mergedNodesDrawn = 0;
  for (Node* n : m.tree->drawList()) {
    if (n->key().span > 1) ++m.stats.mergedNodesDrawn;
    const bool done = n->texture == TextureState::Finished || n->texture == TextureState::Absent ||
                      m.undecodable.contains(n->key());
    complete = complete && done;
    complete = complete && m.heightsComplete(*n);
    const TexturePlan plan = planTexture(*n);
    for (int i = 0; i < plan.partCount; ++i) {
      const TexturePart& p = plan.parts[static_cast<std::size_t>(i)];
      GLuint texture = m.globalTexture;
      UvTransform uv = p.uv;
      if (p.source != TextureSource::Global && p.texture != nullptr) {
        if (auto it = m.textures.find(p.texture->key()); it != m.textures.end()) {
          texture = it->second;
          m.lru.use(p.texture->key());
        } else {
          uv = globalUv(p.region->sector());
        }
      }
      m.parts.push_back(partFor(*n, *p.region, texture, uv));
    }
  }
  (void)lap();
  const std::size_t uploadedBefore = m.stats.bytesUploaded;
  m.stepUploads();
  ph.upload = lap();
  ph.uploadBytes = m.stats.bytesUploaded - uploadedBefore;
  m.evict();
  (void)lap();
  const std::size_t meshesBefore = m.stats.meshesBuilt;
  // Meshes before drawing (a node's mesh depends on which neighbours are drawn, known only now);
  // then the camera once more above the surface they make (the tree may have split under it).
  m.stats.edgesFixed = 0;
  m.stats.zeroAreaTriangles = 0;
  // Coarse first (thesis 4.5.2: edges are fixed in ascending level order), so a finer node adapts
  // to its coarser neighbour's edge as that neighbour draws it.
  m.byLevel.assign(m.tree->drawList().begin(), m.tree->drawList().end());
  std::stable_sort(m.byLevel.begin(), m.byLevel.end(), [](const Node* a, const Node* b) {
    return a->level() < b->level();
  });
  for (const Node* n : m.byLevel)
    m.meshFor(*n);
  // A second pass for the rare neighbour that is coarser along an edge at a deeper level (merged
  // polar rows): its mesh was not yet final when the first pass reached the finer node.
  for (const Node* n : m.byLevel) {
    const GpuMesh& g = m.meshFor(*n);
    for (const EdgeAdapt& e : g.edges)
      m.stats.edgesFixed += e.active ? 1 : 0;
    m.stats.zeroAreaTriangles += g.zeroAreaTriangles;
  }
  if (const CameraPose again = clampToTerrain(safe); again.altitudeM != safe.altitudeM) {
    safe = again;
    cam = camera(safe);
    m.stats.cameraLifted = true;
    m.drawnPose = safe;
  }
  ph.meshesCreated = m.stats.meshesBuilt - meshesBefore;
  ph.mesh = lap();
  m.draw(cam);
  ph.draw = lap();

  // Tiles that arrived for nodes gone from view are dropped after a while (asked again if needed).
  if (m.stats.frames % 64 == 0) {
    std::erase_if(m.received, [&](const auto& e) {
      if (m.stats.frames - e.second.frame < 600) return false;
      m.streamer->forget({e.first.level, e.first.row, e.first.col, 1});
      return true;
    });
    std::erase_if(m.meshes, [&](auto& e) {
      if (m.stats.frames - e.second.lastUsed < 120) return false;
      glDeleteVertexArrays(1, &e.second.vao);
      glDeleteBuffers(1, &e.second.vbo);
      glDeleteBuffers(1, &e.second.ebo);
      return true;
    });
  }
  if (m.window != nullptr && m.opt.visibleWindow) glfwPollEvents();
  (void)lap();
  glFinish();
  ph.finish = lap();

  const StreamStats& ss = m.streamer->stats();
  m.lastComplete = complete && ss.inFlight == 0 && m.decoding.empty() && m.uploads.empty() &&
                   m.decoder.pending() == 0 && !(m.heights && m.heights->busy());
  RenderStats& s = m.stats;
  s.nodesVisible = fs.visible;
  s.nodesDrawn = fs.drawn;
  s.nodesCreated = fs.created;
  s.nodesCreatedTotal += fs.created;
  s.nodesInTree = fs.nodes;
  s.maxLevel = fs.maxLevel;
  s.tilesRequested = ss.requested;
  s.tilesReceived = ss.received;
  s.tilesAbsent = ss.absent;
  s.tilesFailed = ss.failed;
  s.tilesInFlight = ss.inFlight;
  s.decodesPending = m.decoder.pending();
  s.uploadsPending = m.uploads.size();
  s.texturesResident = m.lru.count();
  s.textureBytes = m.lru.bytes();
  s.poolTextures = m.pool.size();
  s.frameMs = msSince(t0);
  ph.total = s.frameMs;
  s.phases = ph;
  m.pacer.recordFrame(ph.total, ph.upload);
}

bool Renderer::complete() const noexcept {
  return impl_->lastComplete;
}

bool Renderer::busy() const noexcept {
  const Impl& m = *impl_;
  return m.streamer->stats().inFlight > 0 || !m.decoding.empty() || !m.uploads.empty() ||
         m.decoder.pending() > 0 || (m.heights && m.heights->busy());
}

std::vector<std::uint8_t> Renderer::readPixels() const {
  const Impl& m = *impl_;
  if (m.window != nullptr) glfwMakeContextCurrent(m.window);
  const auto w = static_cast<std::size_t>(m.opt.width), h = static_cast<std::size_t>(m.opt.height);
  std::vector<std::uint8_t> bottomUp(w * h * 4), out(w * h * 4);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, m.fbo);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glReadPixels(0, 0, m.opt.width, m.opt.height, GL_RGBA, GL_UNSIGNED_BYTE, bottomUp.data());
  for (std::size_t y = 0; y < h; ++y)
    std::copy_n(bottomUp.data() + (h - 1 - y) * w * 4, w * 4, out.data() + y * w * 4);
  return out;
}

const RenderStats& Renderer::stats() const noexcept {
  return impl_->stats;
}
int Renderer::width() const noexcept {
  return impl_->opt.width;
}
int Renderer::height() const noexcept {
  return impl_->opt.height;
}
bool Renderer::windowShouldClose() const noexcept {
  return impl_->window != nullptr && glfwWindowShouldClose(impl_->window) == GLFW_TRUE;
}
void* Renderer::nativeWindow() const noexcept {
  return impl_->opt.visibleWindow ? impl_->window : nullptr;
}

void Renderer::resize(int width, int height) {
  Impl& m = *impl_;
  if (width <= 0 || height <= 0 || (width == m.opt.width && height == m.opt.height)) return;
  glfwMakeContextCurrent(m.window);
  m.freeFramebuffer();
  m.opt.width = width;
  m.opt.height = height;
  m.makeFramebuffer();
}

} // namespace tellus::planet
