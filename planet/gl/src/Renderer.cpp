// The GL layer of the planet renderer: see Renderer.hpp and docs/ARCHITECTURE.md ("The planet
// renderer"). Every GL call here runs on the thread that created the Renderer.

#include "Depth.hpp"
#include "Dome.hpp"
#include "GlShader.hpp"
#include "HeightDecode.hpp"
#include "Shaders.hpp"
#include "TextOverlay.hpp"
#include "TextureDecoder.hpp"
#include "UploadPacer.hpp"

#include <tellus/planet/GpuVertex.hpp>
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
#include <numbers>
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

struct GpuMesh {
  GLuint vao = 0;
  GLuint vbo = 0;
  GLuint ebo = 0;
  std::array<std::uint32_t, 5> quadrantStart{};
  std::size_t zeroAreaTriangles = 0;
  std::array<EdgeAdapt, 4> edges{};
  bool reliefOff = false; ///< built on the bare ellipsoid (Impl::chooseRelief)
  std::uint64_t heightGeneration = 0;
  std::uint64_t lastUsed = 0;
  bool fixed = false; ///< some side adapted
  /** The n vertices along each side (Direction order) as drawn: what finer neighbours adapt to. */
  std::array<std::vector<glm::dvec3>, 4> sideVertices;
};

struct Upload {
  DecodedTexture texture; ///< its tag names the layer (LayerTextures::tag)
  GLuint id = 0;
  std::size_t level = 0;
  int row = 0;
};

struct StoredTile {
  std::vector<std::byte> bytes;
  std::string contentType;
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
  std::uint32_t overlayBegin = 0; ///< its overlays: Impl::bindings[overlayBegin, overlayEnd)
  std::uint32_t overlayEnd = 0;
};

/** One overlay's texture on a drawn part: the texture, the transform of the node's coordinates
 * into it, and the layer's opacity. */
struct OverlayBinding {
  GLuint texture;
  UvTransform uv;
  float opacity;
};

/** uvNode -> uvTexture, given uvRegion -> uvTexture, for a region that is the node or a child. */
UvTransform regionToNodeUv(const Node& node, const Node& region, const UvTransform& regionUv) {
  if (&region == &node) return regionUv;
  const Sector& s = node.sector();
  const Sector& c = region.sector();
  const double w = s.east - s.west, h = s.north - s.south;
  const glm::dvec2 k{w / (c.east - c.west), h / (c.north - c.south)};
  const glm::dvec2 o{(c.west - s.west) / w, (c.south - s.south) / h};
  // uvRegion = (uvNode - o) * k, then the region's transform.
  UvTransform t;
  t.scale = k * regionUv.scale;
  t.offset = regionUv.offset - o * k * regionUv.scale;
  return t;
}

/** One layer at one time: its own tree (LOD and stream order in its grid, the same camera as the
 * base), its tiles, decodes, uploads and resident textures (issue #7). The base layer's tree is
 * also the geometry every layer is drawn on. */
struct LayerTextures {
  int tag = 0; ///< unique for the renderer's life (decode jobs and uploads carry it)
  std::string layer;
  std::string time;
  bool overlay = false;
  TileGrid grid;
  int texWidth = 0, texHeight = 0;
  GLsizei texLevels = 1;
  std::unique_ptr<Quadtree> tree;
  std::unique_ptr<TextureStreamer> streamer;
  TextureLru lru;
  std::unordered_map<NodeKey, GLuint, NodeKeyHash> textures;
  std::vector<GLuint> pool;        ///< free textures of this layer's size
  std::unordered_set<GLuint> wide; ///< textures of polar caps (wider): never pooled
  std::unordered_map<TileKey, StoredTile, TileKeyHash> received;
  std::unordered_set<NodeKey, NodeKeyHash> decoding;
  std::unordered_set<NodeKey, NodeKeyHash> uploading;
  std::unordered_set<NodeKey, NodeKeyHash> undecodable;
  bool updated = false; ///< its tree was updated this frame
  /** How far its meshes' triangles reach below the ellipsoid (its roots' chords, the coarsest):
   * the horizon occluder sits that much lower (Impl::applyTerrain). */
  double chordDepthM = 0.0;

  LayerTextures(TileGrid g, std::size_t budget) : grid(g), lru(budget) {}
  /** Nothing in flight, decoding or uploading. */
  bool idle() const {
    return streamer->stats().inFlight == 0 && decoding.empty() && uploading.empty();
  }
  /** The node shows what it will show: its own texture, or none exists (absent, undecodable)
   * and its nearest ancestor that is not absent shows its own. */
  bool done(const Node& n) const {
    const auto own = [&](const Node& x) {
      return x.texture == TextureState::Finished || undecodable.contains(x.key());
    };
    if (own(n)) return true;
    if (n.texture != TextureState::Absent) return false;
    for (const Node* a = n.parent(); a != nullptr; a = a->parent())
      if (a->texture != TextureState::Absent) return own(*a);
    return true;
  }
};

/** A layer as the user sees it: its settings, its textures at the current time, and those of a
 * time it is switching to (swapped in whole once ready). */
struct LayerSlot {
  LayerOptions opt;
  std::unique_ptr<LayerTextures> current;
  std::unique_ptr<LayerTextures> pending;
  std::size_t swaps = 0;
  std::size_t retiredRequested = 0; ///< tiles of times no longer drawn
  std::size_t retiredReceived = 0;
};

/** The part of `node` under `region` (the node itself or one of its children): which quadrant
 * ranges, and the uv transform for the node's coordinates given the one for region's. */
DrawPart
partFor(const Node& node, const Node& region, GLuint texture, const UvTransform& regionUv) {
  DrawPart d{&node, texture, regionUv, 0, 4};
  if (&region == &node) return d;
  const Sector& s = node.sector();
  const Sector& c = region.sector();
  d.uv = regionToNodeUv(node, region, regionUv);
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
      : source(s), geodesy(g), opt(std::move(o)), grid(gr),
        decoder(opt.decodeThreads, opt.decodeNice, opt.imageDecoder),
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
  GLint uBase = -1, uOverlayCount = -1, uOverlayUv = -1, uOverlayOpacity = -1;
  int overlaysPerPass = 1; ///< overlay textures one pass blends (texture units 1..)
  bool fp64 = false;       ///< vertex positions as doubles (GL 4.x), else high/low float pairs
  GLuint globalTexture = 0;
  float anisotropy = 1.0f; ///< what the GL allows of opt.anisotropy

  std::vector<LayerSlot> layers; ///< [0] the base imagery, then the overlays in drawing order
  int nextTag = 1;
  /** The base layer's tree: what is drawn, and the geometry of every layer. */
  Quadtree& geo() const { return *layers.front().current->tree; }
  LayerTextures* byTag(int tag) const {
    for (const LayerSlot& l : layers) {
      if (l.current && l.current->tag == tag) return l.current.get();
      if (l.pending && l.pending->tag == tag) return l.pending.get();
    }
    return nullptr;
  }
  std::unique_ptr<HeightField> field; // null without an elevation layer
  std::unique_ptr<HeightStreamer> heights;
  std::vector<TileKey> heightWish;
  std::vector<const Node*> byLevel;
  TextureDecoder decoder;
  UploadPacer pacer;
  std::unordered_map<NodeKey, GpuMesh, NodeKeyHash> meshes;
  std::deque<Upload> uploads;
  std::vector<DrawPart> parts;
  std::vector<OverlayBinding> bindings;
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
  std::expected<std::unique_ptr<LayerTextures>, std::string>
  makeLayer(const std::string& name, const std::string& time, bool overlay, int maxLevel);
  void applyTerrain(LayerTextures& l) const;
  void freeLayer(LayerTextures& l);
  GLuint newNodeTexture(int width, int height);
  GLuint acquireTexture(LayerTextures& l, int width, int height);
  void releaseTexture(LayerTextures& l, GLuint id);
  const GpuMesh& meshFor(const Node& node);
  double heightAt(double lat, double lon) const {
    return field && !reliefOff ? field->heightAt(lat, lon) * opt.verticalExaggeration : 0.0;
  }
  std::array<EdgeAdapt, 4> edgesOf(const Node& node) const;
  double surfaceHeightAt(double lat, double lon) const;
  CameraPose drawnPose{};
  void updateTerrain(double nowS);
  /** "Model only what a scene requires": whether any relief could show from this camera
   * (RendererOptions::terrainMinReliefPx); a pure function of the camera, so a frame's image does
   * not depend on the heights earlier frames loaded. Switching re-applies the heights (flat or
   * not) to every tree and marks every mesh stale. */
  void chooseRelief(const Camera& camera, double altitudeM);
  bool reliefOff = false; ///< this frame draws the bare ellipsoid and fetches no heights
  void deliverHeights();
  bool heightsComplete(const Node& node) const;
  /** The elevation level a node's mesh needs (samples as fine as its grid); for a cap, the finest
   * level whose tiles over the whole cap number at most kCapHeightKeys. */
  int heightLevelFor(const Node& node) const;
  static constexpr std::size_t kCapHeightKeys = 64;
  /** A cap's mesh made whole: its two seam columns (longitude -180 and 180) bit-identical. (The
   * ring's nodes put their edges onto its rim's chords: buildTerrainMesh.) */
  static void closeCap(TerrainMesh& mesh);
  void launchDecode(LayerTextures& l, Node& node);
  void stepUploads();
  void evict(LayerTextures& l);
  void bindOverlays(const Node& region, DrawPart& part);
  bool ready(const LayerTextures& l) const;
  /** The levels a slot's layer has under its maximum level (what a fresh LayerTextures gets). */
  std::int32_t levelsFor(const LayerSlot& slot) const {
    const auto spec = source.describe(slot.opt.layer, slot.current->time);
    if (!spec) return slot.current->grid.numLevels();
    return slot.opt.maxLevel >= 0 ? std::min(spec->grid.numLevels, slot.opt.maxLevel + 1)
                                  : spec->grid.numLevels;
  }
  void swapReadyLayers();
  std::unique_ptr<Dome> dome; // opt.dome: the cube faces and the warp (Dome.hpp)
  void draw(const Camera& camera, bool present = true, const DrawTarget* target = nullptr);
  void warmUp();
};

Renderer::Impl::~Impl() {
  if (window != nullptr) {
    glfwMakeContextCurrent(window);
    dome.reset();
    for (auto& [k, m] : meshes) {
      glDeleteVertexArrays(1, &m.vao);
      glDeleteBuffers(1, &m.vbo);
      glDeleteBuffers(1, &m.ebo);
    }
    for (LayerSlot& l : layers) {
      if (l.current) freeLayer(*l.current);
      if (l.pending) freeLayer(*l.pending);
    }
    for (auto& u : uploads)
      glDeleteTextures(1, &u.id);
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
  std::string defines = fp64 ? "#define TELLUS_FP64 1\n" : "";
  if (opt.dome && opt.dome->method == DomeMethod::Direct) defines += "#define TELLUS_FISHEYE 1\n";
  // Overlay layers blended in one pass: one texture unit each after the base's (unit 0).
  GLint units = 16;
  glGetIntegerv(GL_MAX_TEXTURE_IMAGE_UNITS, &units);
  overlaysPerPass = std::clamp(units - 1, 1, 8);
  if (opt.overlaysPerPass > 0) overlaysPerPass = std::min(overlaysPerPass, opt.overlaysPerPass);
  stats.overlaysPerPass = overlaysPerPass;
  std::string fragDefines = "#define TELLUS_OVERLAYS " + std::to_string(overlaysPerPass) +
                            "\n#define TELLUS_OVERLAY_STEPS";
  for (int i = 0; i < overlaysPerPass; ++i)
    fragDefines += " TELLUS_OVERLAY(" + std::to_string(i) + ")";
  fragDefines += "\n";
  auto linked = linkProgram(
      header + defines + kShader_planet_vert, header + fragDefines + kShader_planet_frag, "shader");
  if (!linked) return linked.error();
  program = linked->release(); // until the renderer holds handles too
  uViewProj = glGetUniformLocation(program, "uViewProj");
  uEye = glGetUniformLocation(program, "uEye");
  uEyeHigh = glGetUniformLocation(program, "uEyeHigh");
  uEyeLow = glGetUniformLocation(program, "uEyeLow");
  uUv = glGetUniformLocation(program, "uUv");
  uTexture = glGetUniformLocation(program, "uTexture");
  uSun = glGetUniformLocation(program, "uSun");
  uBase = glGetUniformLocation(program, "uBase");
  uOverlayCount = glGetUniformLocation(program, "uOverlayCount");
  uOverlayUv = glGetUniformLocation(program, "uOverlayUv");
  uOverlayOpacity = glGetUniformLocation(program, "uOverlayOpacity");
  glUseProgram(program);
  for (int i = 0; i < overlaysPerPass; ++i)
    glUniform1i(glGetUniformLocation(program, ("uOverlay[" + std::to_string(i) + "]").c_str()),
                1 + i);
  glUseProgram(0);

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
  // 32-bit float depth with reversed Z: 0.1 m to 1e9 m in one frustum (Depth.hpp).
  glBindRenderbuffer(GL_RENDERBUFFER, depthRb);
  glRenderbufferStorage(GL_RENDERBUFFER, kDepthFormat, opt.width, opt.height);
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

// The GL objects of a layer (its textures and pool); the caller forgets the layer.
void Renderer::Impl::freeLayer(LayerTextures& l) {
  for (auto& [k, t] : l.textures)
    glDeleteTextures(1, &t);
  l.textures.clear();
  if (!l.pool.empty()) glDeleteTextures(static_cast<GLsizei>(l.pool.size()), l.pool.data());
  l.pool.clear();
}

// Heights (node bounds, the horizon occluder) for a layer's tree, from the field. The occluder lies
// under everything drawn: below the lowest height, less the depth of the coarsest chords (a
// level-zero tile's flat triangles sag ~600 m under the ellipsoid, a polar cap's rim cells more),
// so the horizon test never culls what shows over a sagging triangle nearer the camera.
void Renderer::Impl::applyTerrain(LayerTextures& l) const {
  Quadtree& t = *l.tree;
  if (!field) {
    t.setTerrain({}, -l.chordDepthM);
    return;
  }
  const Impl* self = this;
  t.setTerrain(
      [self](const Sector& sec) {
        if (self->reliefOff) return std::pair{0.0, 0.0};
        const auto [lo, hi] = self->field->rangeOver(sec);
        return std::pair{lo * self->opt.verticalExaggeration, hi * self->opt.verticalExaggeration};
      },
      (reliefOff ? 0.0 : std::min(0.0, field->lowest() * opt.verticalExaggeration)) -
          l.chordDepthM);
}

// A layer at a time: its grid (an overlay's must match the base's level-zero tile size), its tree
// with the base's LOD settings and its own tile size, its streamer, and its share of the texture
// budget.
std::expected<std::unique_ptr<LayerTextures>, std::string> Renderer::Impl::makeLayer(
    const std::string& name, const std::string& time, bool overlay, int maxLevel) {
  const auto spec = source.describe(name, time);
  if (!spec) return std::unexpected("unknown layer '" + name + "'");
  GridSpec gs = spec->grid;
  if (maxLevel >= 0) gs.numLevels = std::min(gs.numLevels, maxLevel + 1);
  auto g = TileGrid::create(gs);
  if (!g) return std::unexpected("layer '" + name + "': " + g.error());
  if (overlay && gs.levelZeroDeltaDeg != grid.spec().levelZeroDeltaDeg)
    return std::unexpected("overlay '" + name + "' has " + std::to_string(gs.levelZeroDeltaDeg) +
                           "-degree level-zero tiles, the base layer " +
                           std::to_string(grid.spec().levelZeroDeltaDeg) +
                           ": an overlay must share the base layer's grid");
  const std::size_t share = opt.textureBudgetBytes / (1 + opt.overlays.size());
  auto l = std::make_unique<LayerTextures>(*g, std::max<std::size_t>(share, 1));
  l->tag = nextTag++;
  l->layer = name;
  l->time = time;
  l->overlay = overlay;
  l->texWidth = gs.tileWidth;
  l->texHeight = gs.tileHeight;
  l->texLevels =
      static_cast<GLsizei>(std::floor(std::log2(std::max(l->texWidth, l->texHeight))) + 1);
  QuadtreeParams qp;
  qp.lod.tileWidthPx = l->texWidth;
  qp.lod.tileHeightPx = l->texHeight;
  qp.lod.threshold = opt.lodThreshold;
  qp.maxSplitsPerFrame = opt.maxSplitsPerFrame;
  l->tree = std::make_unique<Quadtree>(geodesy, *g, qp);
  l->chordDepthM = l->tree->chordDepthM(opt.meshSize);
  applyTerrain(*l);
  StreamParams sp;
  sp.layer = name;
  sp.time = time;
  sp.maxInFlight = opt.maxInFlight;
  l->streamer = std::make_unique<TextureStreamer>(source, sp);
  return l;
}

GLuint Renderer::Impl::newNodeTexture(int texWidth, int texHeight) {
  // Every level down to 1 x 1, as the decoder builds them.
  const auto texLevels =
      static_cast<GLsizei>(std::floor(std::log2(std::max(texWidth, texHeight))) + 1);
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

// Every node texture of a layer has its grid's tile size, so any freed one fits the next node.
GLuint Renderer::Impl::acquireTexture(LayerTextures& l, int width, int height) {
  if (width != l.texWidth || height != l.texHeight) { // a polar cap's
    const GLuint id = newNodeTexture(width, height);
    l.wide.insert(id);
    return id;
  }
  if (!l.pool.empty()) {
    const GLuint id = l.pool.back();
    l.pool.pop_back();
    ++stats.texturesReused;
    return id;
  }
  return newNodeTexture(l.texWidth, l.texHeight);
}

void Renderer::Impl::releaseTexture(LayerTextures& l, GLuint id) {
  constexpr std::size_t kMaxPool = 64;
  if (l.wide.erase(id) > 0)
    glDeleteTextures(1, &id);
  else if (l.pool.size() < kMaxPool)
    l.pool.push_back(id);
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
  const std::uint64_t frame = geo().frame();
  for (int d = 0; d < 4; ++d) {
    const auto dir = static_cast<Direction>(d);
    const bool alongLon = dir == Direction::North || dir == Direction::South;
    const Node* nb = node.neighbour(dir);
    while (nb != nullptr && nb->lastDrawnFrame() != frame) {
      const Node* next = nullptr;
      const Sector& p = nb->sector();
      for (int slot = 0; slot < nb->childSlots() && next == nullptr; ++slot) {
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
  bool stale =
      m.reliefOff != reliefOff || (field && field->changedSince(m.heightGeneration, node.sector()));
  for (const EdgeAdapt& e : edges)
    stale = stale || (field && e.active && field->changedSince(m.heightGeneration, e.coarse));
  if (!inserted && edges == m.edges && !stale) return m;
  const auto t0 = Clock::now();
  TerrainMesh mesh = buildTerrainMesh(
      geodesy,
      node.sector(),
      node.meshSize(opt.meshSize),
      [this](double lat, double lon) { return heightAt(lat, lon); },
      edges,
      opt.meshSize);
  if (node.isCap()) closeCap(mesh);
  m.edges = edges;
  m.reliefOff = reliefOff;
  m.heightGeneration = field ? field->generation() : 0;
  m.quadrantStart = mesh.quadrantStart;
  m.zeroAreaTriangles = mesh.zeroAreaTriangles;
  m.fixed = std::any_of(edges.begin(), edges.end(), [](const EdgeAdapt& a) { return a.active; });
  {
    const int n = mesh.n, rows = mesh.rows;
    for (int d = 0; d < 4; ++d) {
      auto& side = m.sideVertices[static_cast<std::size_t>(d)];
      const bool alongLon =
          d == static_cast<int>(Direction::North) || d == static_cast<int>(Direction::South);
      side.resize(static_cast<std::size_t>(alongLon ? n : rows));
      for (int i = 0; i < static_cast<int>(side.size()); ++i) {
        const int r = d == static_cast<int>(Direction::North)   ? rows - 1
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
  // 44 bytes a vertex either way (GpuVertex.hpp): the position as three doubles (fp64) or as
  // high and low floats (positions then reach the shader relative to the camera without a float
  // ever holding an Earth-sized coordinate, and two nodes that hold the same point draw it at the
  // same place bit for bit), then the normal and the node uv as floats.
  std::vector<float> v;
  packVertices(mesh.vertices, fp64 ? VertexPositions::Doubles : VertexPositions::FloatPairs, v);
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
void Renderer::Impl::chooseRelief(const Camera& camera, double altitudeM) {
  bool off = false;
  if (field && opt.terrainMinReliefPx > 0.0 && std::isfinite(altitudeM)) {
    // Relief of at most B along the normal, seen from at least D away (the altitude above the
    // ellipsoid is the distance to its nearest point), moves a point by at most B f / D pixels.
    const double bound =
        std::max(opt.terrainReliefBoundM, -field->lowest()) * opt.verticalExaggeration;
    const double f = camera.isFisheye()
                         ? camera.pixelsPerRadian()
                         : 0.5 * camera.viewport().height /
                               std::tan(camera.verticalFovDeg() * std::numbers::pi / 360.0);
    const double distance = altitudeM - bound;
    off = distance > 0.0 && bound * f / distance < opt.terrainMinReliefPx;
  }
  if (off == reliefOff) return;
  reliefOff = off;
  for (LayerSlot& l : layers)
    for (LayerTextures* t : {l.current.get(), l.pending.get()}) {
      if (t == nullptr) continue;
      applyTerrain(*t);
      t->tree->refreshHeights([](const Sector&) { return true; });
    }
}

void Renderer::Impl::updateTerrain(double nowS) {
  if (!field) return;
  heightWish.clear();
  stats.nodesWithoutHeights = reliefOff ? geo().drawList().size() : 0;
  for (const Node* node : geo().drawList()) {
    if (reliefOff) break;
    const Sector& s = node->sector();
    const int level = heightLevelFor(*node);
    for (int l = 0; l <= level; l = l == level ? level + 1 : std::min(level, l + 3)) {
      const auto keys = field->grid().keysCovering(s, l, node->isCap() ? kCapHeightKeys : 16);
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
    // Every layer's tree: their LOD and culling must agree with the geometry drawn.
    for (LayerSlot& l : layers)
      for (LayerTextures* t : {l.current.get(), l.pending.get()}) {
        if (t == nullptr) continue;
        t->tree->refreshHeights(
            [&](const Sector& sec) { return field->changedSince(before, sec); });
        applyTerrain(*t);
      }
  }
}

int Renderer::Impl::heightLevelFor(const Node& node) const {
  const Sector& s = node.sector();
  int level = field->levelForSpacing((s.north - s.south) / (opt.meshSize - 1)); // its rows
  if (node.isCap())
    while (level > 0 && !field->grid().keysCovering(s, level, kCapHeightKeys))
      --level;
  return level;
}

void Renderer::Impl::closeCap(TerrainMesh& mesh) {
  const int n = mesh.n;
  for (int r = 0; r < mesh.rows; ++r) {
    const auto row = static_cast<std::size_t>(r * n);
    mesh.vertices[row + static_cast<std::size_t>(n - 1)].position = mesh.vertices[row].position;
  }
}

bool Renderer::Impl::heightsComplete(const Node& node) const {
  if (!field || reliefOff) return true;
  const Sector& s = node.sector();
  const auto keys =
      field->grid().keysCovering(s, heightLevelFor(node), node.isCap() ? kCapHeightKeys : 16);
  if (!keys) return true;
  return std::all_of(
      keys->begin(), keys->end(), [&](const TileKey& k) { return heights->settled(k, *field); });
}

// A node whose tiles all arrived (TextureState::Decoding): its bytes go to a decoder worker.
void Renderer::Impl::launchDecode(LayerTextures& l, Node& node) {
  auto& uploading = l.uploading;
  auto& decoding = l.decoding;
  auto& received = l.received;
  auto& streamer = l.streamer;
  const NodeKey& k = node.key();
  if (uploading.contains(k)) {
    node.texture = TextureState::Uploading;
    return;
  }
  if (node.texture != TextureState::Decoding || decoding.contains(k) || l.undecodable.contains(k))
    return;
  if (l.lru.resident(k)) return;
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
  job.width = node.isCap() ? l.texWidth * kCapTextureWidthFactor : l.texWidth;
  job.height = l.texHeight;
  job.tileWidth = l.texWidth;
  job.tileHeight = l.texHeight;
  job.transparent = l.overlay;
  job.tag = l.tag;
  for (std::int64_t i = 0; i < textureTileCount(k); ++i) {
    const auto it = received.find(textureTile(k, i));
    if (it == received.end()) {
      job.tiles.emplace_back(std::nullopt);
      job.contentTypes.emplace_back();
    } else {
      job.tiles.emplace_back(std::move(it->second.bytes));
      job.contentTypes.push_back(std::move(it->second.contentType));
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
    LayerTextures* l = byTag(u.texture.tag);
    if (l == nullptr) { // its layer was swapped out or dropped meanwhile
      if (u.id != 0) glDeleteTextures(1, &u.id);
      uploads.pop_front();
      continue;
    }
    if (u.id == 0)
      u.id = acquireTexture(*l, u.texture.levels.front().width, u.texture.levels.front().height);
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
    if (auto old = l->textures.find(key); old != l->textures.end()) releaseTexture(*l, old->second);
    l->textures[key] = u.id;
    l->lru.insert(key, u.texture.bytes);
    l->uploading.erase(key);
    ++stats.texturesUploaded;
    uploads.pop_front();
  }
}

// Textures the LRU let go: back to the pool, their tiles may be fetched again, and any node still
// marked Finished for them falls back from now on.
void Renderer::Impl::evict(LayerTextures& l) {
  const auto evicted = l.lru.takeEvicted();
  if (evicted.empty()) return;
  std::unordered_set<NodeKey, NodeKeyHash> gone;
  for (const NodeKey& k : evicted) {
    if (auto it = l.textures.find(k); it != l.textures.end()) {
      releaseTexture(l, it->second);
      l.textures.erase(it);
    }
    l.streamer->forget(k);
    gone.insert(k);
    ++stats.texturesEvicted;
  }
  l.tree->forEach([&](Node& n) {
    if (n.texture == TextureState::Finished && gone.contains(n.key()))
      n.texture = TextureState::NoTexture;
  });
}

void Renderer::Impl::draw(const Camera& camera, bool present, const DrawTarget* target) {
  // The dome: each face through this function into its cube face, the warp into fbo, then only
  // the presentation below (the scene is not drawn again).
  const DrawTarget warped{fbo, opt.width, opt.height, nullptr, false};
  // The direct method draws the scene once through the fisheye map (Dome::beginDirect), unless
  // the frame's straight edges would be off by more than directMaxErrorPx (DomeDirect.hpp).
  bool direct = false;
  if (dome && target == nullptr && camera.isFisheye()) {
    stats.domeErrorPx = 0.0;
    stats.domeError.clear(); // of this frame only: a later fallback may make the faces
    if (opt.dome->method == DomeMethod::Direct) {
      stats.domeErrorPx = directChordErrorPx(camera,
                                             geo().drawList(),
                                             opt.meshSize,
                                             heightAt(camera.pose().latDeg, camera.pose().lonDeg));
      direct = stats.domeErrorPx <= opt.dome->directMaxErrorPx;
    }
    stats.domeMethod = direct ? "direct" : "cube";
  }
  if (dome && target == nullptr && camera.isFisheye() && !direct) {
    // A direct renderer makes its cube faces on its first fallback (Dome::render). Should that
    // fail (GPU memory), the frame is drawn direct, over the error bound, and says so.
    const auto drawn = dome->render(
        camera,
        [this](const Camera& face, const DrawTarget& t) { draw(face, false, &t); },
        fbo,
        opt.width,
        opt.height);
    if (drawn) {
      target = &warped;
    } else {
      stats.domeError = drawn.error();
      direct = opt.dome->method == DomeMethod::Direct;
      if (direct) stats.domeMethod = "direct";
    }
  }
  if (dome) stats.domeFaceBytes = dome->faceBytes();
  glBindFramebuffer(GL_FRAMEBUFFER, target ? target->fbo : fbo);
  glViewport(0, 0, target ? target->width : opt.width, target ? target->height : opt.height);
  beginReversedZ(stats.reversedZ);
  glClearColor(static_cast<float>(opt.background[0]),
               static_cast<float>(opt.background[1]),
               static_cast<float>(opt.background[2]),
               1.0f);
  if (target == nullptr || target->scene) glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
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
    const glm::dvec3& eye = camera.position();
    const SplitDouble x = splitDouble(eye.x), y = splitDouble(eye.y), z = splitDouble(eye.z);
    glUniform3f(uEyeHigh, x.high, y.high, z.high);
    glUniform3f(uEyeLow, x.low, y.low, z.low);
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
  if (direct) dome->beginDirect(program, camera, opt.width, opt.height);
  // Pass 0: the base texture and the first overlaysPerPass overlays of each part. Pass j > 0: the
  // parts with more overlays, drawn again with the next ones, blended over (same mesh, depth equal
  // passes, nothing written to depth).
  const auto k = static_cast<std::uint32_t>(overlaysPerPass);
  std::uint32_t most = 0;
  for (const DrawPart& p : parts)
    most = std::max(most, p.overlayEnd - p.overlayBegin);
  const std::uint32_t passes = std::max<std::uint32_t>(1, (most + k - 1) / k);
  stats.passes = static_cast<int>(passes);
  std::array<GLfloat, 32> uvs{};
  std::array<GLfloat, 8> opacities{};
  for (std::uint32_t pass = 0; pass < passes; ++pass) {
    glUniform1f(uBase, pass == 0 ? 1.0f : 0.0f);
    if (pass == 1) {
      glEnable(GL_BLEND);
      glBlendFuncSeparate(GL_ONE, GL_ONE_MINUS_SRC_ALPHA, GL_ZERO, GL_ONE);
      glDepthFunc(GL_GEQUAL);
      glDepthMask(GL_FALSE);
    }
    for (const DrawPart& p : parts) {
      if (target && !target->draws(*p.node)) continue;
      const std::uint32_t from = std::min(p.overlayEnd, p.overlayBegin + pass * k);
      const std::uint32_t count = std::min(k, p.overlayEnd - from);
      if (pass > 0 && count == 0) continue;
      const GpuMesh& m = meshFor(*p.node);
      const std::array<float, 4> uv = uvUniform(p.uv);
      glUniform4f(uUv, uv[0], uv[1], uv[2], uv[3]);
      for (std::uint32_t i = 0; i < count; ++i) {
        const OverlayBinding& b = bindings[from + i];
        glActiveTexture(GL_TEXTURE1 + i);
        glBindTexture(GL_TEXTURE_2D, b.texture);
        const std::array<float, 4> u = uvUniform(b.uv);
        std::copy(u.begin(), u.end(), uvs.begin() + static_cast<std::ptrdiff_t>(4 * i));
        opacities[i] = b.opacity;
      }
      glUniform1i(uOverlayCount, static_cast<GLint>(count));
      if (count > 0) {
        glUniform4fv(uOverlayUv, static_cast<GLsizei>(count), uvs.data());
        glUniform1fv(uOverlayOpacity, static_cast<GLsizei>(count), opacities.data());
      }
      glActiveTexture(GL_TEXTURE0);
      glBindTexture(GL_TEXTURE_2D, p.texture);
      glBindVertexArray(m.vao);
      const std::uint32_t first = m.quadrantStart[static_cast<std::size_t>(p.firstQuadrant)];
      const std::uint32_t last = m.quadrantStart[static_cast<std::size_t>(p.lastQuadrant)];
      glDrawElements(GL_TRIANGLES,
                     static_cast<GLsizei>(last - first),
                     GL_UNSIGNED_INT,
                     reinterpret_cast<const void*>(static_cast<std::uintptr_t>(first) *
                                                   sizeof(std::uint32_t)));
    }
  }
  if (passes > 1) {
    glDisable(GL_BLEND);
    glDepthFunc(GL_GREATER);
    glDepthMask(GL_TRUE);
  }
  glBindVertexArray(0);
  if (direct) dome->endDirect(program, fbo, opt.width, opt.height);
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
  for (const auto& r : geo().roots())
    if (r && !r->isCap() && root == nullptr) root = r.get();
  if (root == nullptr) return;
  const RenderStats before = stats; // the warm-up counts no mesh, upload or texture
  const LayerTextures& base = *layers.front().current;
  const GLuint texture = newNodeTexture(base.texWidth, base.texHeight);
  const std::uint8_t texel[4] = {0, 0, 0, 255};
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexSubImage2D(GL_TEXTURE_2D, base.texLevels - 1, 0, 0, 1, 1, GL_RGBA, GL_UNSIGNED_BYTE, texel);
  parts.clear();
  bindings.clear();
  parts.push_back({root, globalTexture, globalUv(root->sector())});
  parts.push_back({root, texture, UvTransform{}});
  if (layers.size() > 1) { // the program with overlays, and a second pass
    const auto n = static_cast<std::uint32_t>(overlaysPerPass + 1);
    for (std::uint32_t i = 0; i < n; ++i)
      bindings.push_back({texture, UvTransform{}, 0.0f});
    parts.back().overlayEnd = n;
  }
  const Camera cam(geodesy, CameraPose{}, {opt.width, opt.height}, opt.verticalFovDeg);
  draw(cam, false);
  glFinish();
  parts.clear();
  bindings.clear();
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
  for (const LayerOptions& l : options.overlays)
    if (!(l.opacity >= 0.0 && l.opacity <= 1.0))
      return std::unexpected("overlay '" + l.layer + "': the opacity must be in [0, 1]");
  auto impl = std::make_unique<Impl>(source, geodesy, std::move(options), *grid);
  if (auto err = impl->initGl(); !err.empty()) return std::unexpected(err);
  {
    LayerSlot base;
    base.opt.layer = impl->opt.layer;
    base.opt.time = impl->opt.time;
    auto made = impl->makeLayer(base.opt.layer, base.opt.time, false, -1);
    if (!made) return std::unexpected(made.error());
    base.current = std::move(*made);
    impl->layers.push_back(std::move(base));
    for (const LayerOptions& o : impl->opt.overlays) {
      LayerSlot slot;
      slot.opt = o;
      auto l = impl->makeLayer(o.layer, o.time, true, o.maxLevel);
      if (!l) return std::unexpected(l.error());
      slot.current = std::move(*l);
      impl->layers.push_back(std::move(slot));
    }
  }
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
    for (LayerSlot& l : impl->layers)
      impl->applyTerrain(*l.current);
  }
  if (const auto& d = impl->opt.dome) {
    if (!(d->fovDeg > 0.0 && d->fovDeg <= 220.0) || !std::isfinite(d->tiltDeg))
      return std::unexpected(std::string("the dome's field of view must be in (0, 220] degrees"));
    if (!(d->faceScale > 0.0 && d->faceScale <= 4.0))
      return std::unexpected(std::string("the dome's face scale must be in (0, 4]"));
    const int side = std::min(impl->opt.width, impl->opt.height);
    // The direct method makes the cube faces only when a frame falls back to them.
    auto made = Dome::create(std::max(8, static_cast<int>(std::lround(d->faceScale * side))),
                             impl->gl45 ? "#version 450 core\n" : "#version 330 core\n",
                             d->method == DomeMethod::Cube);
    if (!made) return std::unexpected(made.error());
    impl->dome = std::move(*made);
  }
  impl->warmUp();
  return std::unique_ptr<Renderer>(new Renderer(std::move(impl)));
}

// The height of the surface as drawn, conservatively: the data's height at the point, and the
// heights of the grid cell's corners of the drawn node over it (a coarse node's flat cell can lie
// above the data's valley), including the coarse chord's ends where that side is edge-fixed.
double Renderer::Impl::surfaceHeightAt(double lat, double lon) const {
  double h = heightAt(lat, lon);
  if (layers.empty() || !std::isfinite(h)) return h;
  lon = std::remainder(lon, 360.0);
  for (const Node* node : geo().drawList()) {
    const Sector& s = node->sector();
    if (lat < s.south || lat > s.north || lon < s.west || lon > s.east) continue;
    const int n = node->meshSize(opt.meshSize), rows = opt.meshSize;
    const int r =
        std::clamp(static_cast<int>(std::floor((lat - s.south) / (s.north - s.south) * (rows - 1))),
                   0,
                   rows - 2);
    const int c = std::clamp(
        static_cast<int>(std::floor((lon - s.west) / (s.east - s.west) * (n - 1))), 0, n - 2);
    for (int dr = 0; dr < 2; ++dr)
      for (int dc = 0; dc < 2; ++dc)
        h = std::max(h,
                     heightAt(edgeLerp(s.south, s.north, r + dr, rows),
                              edgeLerp(s.west, s.east, c + dc, n)));
    if (const auto it = meshes.find(node->key()); it != meshes.end())
      for (int d = 0; d < 4; ++d) {
        const EdgeAdapt& e = it->second.edges[static_cast<std::size_t>(d)];
        if (!e.active) continue;
        const bool alongLon =
            d == static_cast<int>(Direction::North) || d == static_cast<int>(Direction::South);
        const double a = alongLon ? e.coarse.west : e.coarse.south,
                     b = alongLon ? e.coarse.east : e.coarse.north;
        const double p = alongLon ? lon : lat;
        // The coarse side's own vertex count (a polar cap's rim has more than n).
        const int cn = e.coarseVertices.size() >= 2 ? static_cast<int>(e.coarseVertices.size()) : n;
        const int j =
            std::clamp(static_cast<int>(std::floor((p - a) / (b - a) * (cn - 1))), 0, cn - 2);
        for (int k = 0; k < 2; ++k) {
          const double q = edgeLerp(a, b, j + k, cn);
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
  if (o.dome) // the faces' near plane: 90-degree square views
    return Camera(impl_->geodesy,
                  pose,
                  std::min(o.width, o.height),
                  Fisheye{o.dome->fovDeg, o.dome->tiltDeg},
                  nearDistanceFor(above, 90.0, 1.0));
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
  m.chooseRelief(cam, safe.altitudeM);
  m.stats.meshesBuiltLast = 0;
  m.stats.meshMs = 0.0;
  if (m.window != nullptr) glfwMakeContextCurrent(m.window);
  ++m.stats.frames;

  // CPU update: the trees and the stream order. The base layer's tree is always updated (it is
  // what is drawn); an overlay's only while visible. A layer switching to another time streams
  // the new time's tiles only (the old time's stop being asked for).
  const double nowS = std::chrono::duration<double>(t0 - m.start).count();
  // A copy: the tree it comes from may be swapped out at the end of this frame (a time change).
  const FrameStats fs = m.geo().update(cam);
  for (std::size_t i = 0; i < m.layers.size(); ++i) {
    LayerSlot& slot = m.layers[i];
    const bool shown = i == 0 || slot.opt.visible;
    for (LayerTextures* l : {slot.current.get(), slot.pending.get()}) {
      if (l == nullptr) continue;
      const bool isPending = l == slot.pending.get();
      l->updated = shown && (isPending || !slot.pending);
      if (!l->updated && !(i == 0 && !isPending)) continue;
      if (l != m.layers.front().current.get()) l->tree->update(cam);
      l->lru.beginFrame();
      if (l->updated) l->streamer->update(*l->tree, cam, nowS, &l->lru);
    }
  }
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

  for (LayerSlot& slot : m.layers)
    for (LayerTextures* l : {slot.current.get(), slot.pending.get()}) {
      if (l == nullptr) continue;
      for (ReceivedTile& r : l->streamer->takeReceived()) {
        m.stats.bytesReceived += r.result.bytes.size();
        l->received[r.key] = {
            std::move(r.result.bytes), std::move(r.result.contentType), m.stats.frames};
      }
      if (!l->updated) continue;
      for (const auto& root : l->tree->roots())
        if (root) m.launchDecode(*l, *root);
      for (Node* n : l->tree->drawList()) {
        m.launchDecode(*l, *n);
        // An absent node shows the nearest ancestor that is not (the streamer asks for it).
        if (n->texture == TextureState::Absent)
          for (Node* a = n->parent(); a != nullptr; a = a->parent())
            if (a->texture != TextureState::Absent) {
              m.launchDecode(*l, *a);
              break;
            }
      }
    }
  for (DecodedTexture& d : m.decoder.takeDone()) {
    LayerTextures* l = m.byTag(d.tag);
    if (l == nullptr) continue; // its layer was swapped out meanwhile
    l->decoding.erase(d.key);
    if (!d.ok) {
      ++m.stats.decodeErrors;
      l->undecodable.insert(d.key);
      continue;
    }
    ++m.stats.texturesDecoded;
    if (l->lru.resident(d.key)) continue;
    Upload u; // its texture is taken when its upload starts (stepUploads)
    u.texture = std::move(d);
    l->uploading.insert(u.texture.key);
    m.uploads.push_back(std::move(u));
  }
  ph.intake = lap();

  // What this frame draws, and the LRU told so before anything new is inserted.
  m.parts.clear();
  m.bindings.clear();
  LayerTextures& base = *m.layers.front().current;
  // The roots stay resident like the global texture: the streamer wants them until they are, so
  // evicting one would only fetch it again (a loop when the budget is small).
  for (const LayerSlot& slot : m.layers)
    for (LayerTextures* l : {slot.current.get(), slot.pending.get()})
      if (l != nullptr)
        for (const auto& root : l->tree->roots())
          if (root) l->lru.use(root->key());
  bool complete = fs.splitsDeferred == 0;
  // Each visible overlay shows what its own LOD asks for, and no layer is switching time.
  for (std::size_t i = 0; i < m.layers.size(); ++i) {
    const LayerSlot& slot = m.layers[i];
    complete = complete && !slot.pending;
    if (i == 0 || !slot.opt.visible) continue;
    const LayerTextures& l = *slot.current;
    for (const Node* n : l.tree->drawList())
      complete = complete && l.done(*n);
  }
  m.stats.mergedNodesDrawn = 0;
  for (Node* n : m.geo().drawList()) {
    if (n->key().span > 1) ++m.stats.mergedNodesDrawn;
    complete = complete && base.done(*n);
    complete = complete && m.heightsComplete(*n);
    const TexturePlan plan = planTexture(*n);
    for (int i = 0; i < plan.partCount; ++i) {
      const TexturePart& p = plan.parts[static_cast<std::size_t>(i)];
      GLuint texture = m.globalTexture;
      UvTransform uv = p.uv;
      if (p.source != TextureSource::Global && p.texture != nullptr) {
        if (auto it = base.textures.find(p.texture->key()); it != base.textures.end()) {
          texture = it->second;
          base.lru.use(p.texture->key());
        } else {
          uv = globalUv(p.region->sector());
        }
      }
      m.parts.push_back(partFor(*n, *p.region, texture, uv));
      m.bindOverlays(*p.region, m.parts.back());
    }
  }
  (void)lap();
  const std::size_t uploadedBefore = m.stats.bytesUploaded;
  m.stepUploads();
  ph.upload = lap();
  ph.uploadBytes = m.stats.bytesUploaded - uploadedBefore;
  for (LayerSlot& slot : m.layers)
    for (LayerTextures* l : {slot.current.get(), slot.pending.get()})
      if (l != nullptr) m.evict(*l);
  (void)lap();
  const std::size_t meshesBefore = m.stats.meshesBuilt;
  // Meshes before drawing (a node's mesh depends on which neighbours are drawn, known only now);
  // then the camera once more above the surface they make (the tree may have split under it).
  m.stats.edgesFixed = 0;
  m.stats.zeroAreaTriangles = 0;
  // Coarse first (thesis 4.5.2: edges are fixed in ascending level order), so a finer node adapts
  // to its coarser neighbour's edge as that neighbour draws it.
  m.byLevel.assign(m.geo().drawList().begin(), m.geo().drawList().end());
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
    for (LayerSlot& slot : m.layers)
      for (LayerTextures* l : {slot.current.get(), slot.pending.get()})
        if (l != nullptr)
          std::erase_if(l->received, [&](const auto& e) {
            if (m.stats.frames - e.second.frame < 600) return false;
            l->streamer->forget({e.first.level, e.first.row, e.first.col, 1});
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

  // A layer whose new time is ready swaps to it, all at once, for the next frame.
  m.swapReadyLayers();
  StreamStats ss;
  bool idle = true;
  m.stats.layers.resize(m.layers.size());
  m.stats.texturesResident = 0;
  m.stats.textureBytes = 0;
  m.stats.poolTextures = 0;
  for (std::size_t i = 0; i < m.layers.size(); ++i) {
    const LayerSlot& slot = m.layers[i];
    RenderStats::Layer& ls = m.stats.layers[i];
    ls.name = slot.opt.layer;
    ls.time = slot.current->time;
    ls.pendingTime = slot.pending ? slot.pending->time : std::string();
    ls.opacity = slot.opt.opacity;
    ls.visible = slot.opt.visible;
    ls.maxLevel = slot.opt.maxLevel;
    ls.levels = slot.current->grid.numLevels();
    ls.swaps = slot.swaps;
    ls.tilesRequested = slot.retiredRequested;
    ls.tilesReceived = slot.retiredReceived;
    ls.texturesResident = slot.current->lru.count();
    for (const LayerTextures* l : {slot.current.get(), slot.pending.get()}) {
      if (l == nullptr) continue;
      const StreamStats& st = l->streamer->stats();
      ls.tilesRequested += st.requested;
      ls.tilesReceived += st.received;
      ss.requested += st.requested;
      ss.received += st.received;
      ss.absent += st.absent;
      ss.failed += st.failed;
      ss.inFlight += st.inFlight;
      idle = idle && l->idle();
      m.stats.texturesResident += l->lru.count();
      m.stats.textureBytes += l->lru.bytes();
      m.stats.poolTextures += l->pool.size();
    }
    ss.requested += slot.retiredRequested;
    ss.received += slot.retiredReceived;
  }
  m.lastComplete = complete && idle && m.uploads.empty() && m.decoder.pending() == 0 &&
                   !(m.heights && m.heights->busy());
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
  s.frameMs = msSince(t0);
  ph.total = s.frameMs;
  s.phases = ph;
  m.pacer.recordFrame(ph.total, ph.upload);
}

// The overlays over one drawn part (the node, or the child region whose texture it shows): each
// visible overlay's texture of the region, else of its nearest ancestor that has one (the
// ancestor's area through an exact uv transform). An overlay with nothing there yet is skipped:
// what lies under it shows.
void Renderer::Impl::bindOverlays(const Node& region, DrawPart& part) {
  part.overlayBegin = static_cast<std::uint32_t>(bindings.size());
  for (std::size_t i = 1; i < layers.size(); ++i) {
    const LayerSlot& slot = layers[i];
    if (!slot.opt.visible || !(slot.opt.opacity > 0.0)) continue;
    LayerTextures& l = *slot.current;
    for (const Node* a = &region; a != nullptr; a = a->parent()) {
      if (a->level() >= l.grid.numLevels()) continue;
      const auto it = l.textures.find(a->key());
      if (it == l.textures.end()) continue;
      l.lru.use(a->key());
      bindings.push_back({it->second,
                          regionToNodeUv(*part.node, region, ancestorUv(region.key(), a->key())),
                          static_cast<float>(slot.opt.opacity)});
      break;
    }
  }
  part.overlayEnd = static_cast<std::uint32_t>(bindings.size());
}

// A layer's new time is ready when every node its LOD draws (and every root) has its texture, or
// has none to get (absent, undecodable, or its fetch failed and waits for a retry: a dead
// upstream must not hold the old time forever).
bool Renderer::Impl::ready(const LayerTextures& l) const {
  if (!l.updated || l.tree->drawList().empty()) return false;
  const auto settled = [&](const Node& n) {
    if (l.done(n)) return true;
    if (l.uploading.contains(n.key()) || l.decoding.contains(n.key())) return false;
    for (std::int64_t i = 0; i < textureTileCount(n.key()); ++i)
      if (l.streamer->state(textureTile(n.key(), i)) == TileFetch::Failed) return true;
    return false;
  };
  for (const auto& root : l.tree->roots())
    if (root && !settled(*root)) return false;
  for (const Node* n : l.tree->drawList())
    if (!settled(*n)) return false;
  return true;
}

void Renderer::Impl::swapReadyLayers() {
  for (LayerSlot& slot : layers) {
    if (!slot.pending || !ready(*slot.pending)) continue;
    slot.retiredRequested += slot.current->streamer->stats().requested;
    slot.retiredReceived += slot.current->streamer->stats().received;
    freeLayer(*slot.current);
    slot.current = std::move(slot.pending);
    ++slot.swaps;
  }
}

std::size_t Renderer::layerCount() const noexcept {
  return impl_->layers.size();
}

void Renderer::setLayerOpacity(std::size_t layer, double opacity) {
  if (layer == 0 || layer >= impl_->layers.size())
    throw std::invalid_argument("only an overlay (layer 1 and up) has an opacity");
  if (!(opacity >= 0.0 && opacity <= 1.0))
    throw std::invalid_argument("the opacity must be in [0, 1]");
  impl_->layers[layer].opt.opacity = opacity;
}

void Renderer::setLayerVisible(std::size_t layer, bool visible) {
  if (layer == 0 || layer >= impl_->layers.size())
    throw std::invalid_argument("only an overlay (layer 1 and up) can be hidden");
  impl_->layers[layer].opt.visible = visible;
}

void Renderer::setLayerMaxLevel(std::size_t layer, int maxLevel) {
  Impl& m = *impl_;
  if (layer >= m.layers.size()) throw std::invalid_argument("no such layer");
  if (maxLevel < -1 || maxLevel > 40)
    throw std::invalid_argument("the maximum level must be -1 (none) or 0 to 40");
  LayerSlot& slot = m.layers[layer];
  if (slot.opt.maxLevel == maxLevel) return;
  slot.opt.maxLevel = maxLevel;
  const std::string time = slot.pending ? slot.pending->time : slot.current->time;
  if (m.window != nullptr) glfwMakeContextCurrent(m.window);
  if (slot.pending) {
    slot.retiredRequested += slot.pending->streamer->stats().requested;
    slot.retiredReceived += slot.pending->streamer->stats().received;
    m.freeLayer(*slot.pending);
    slot.pending.reset();
  }
  auto l = m.makeLayer(slot.opt.layer, time, layer > 0, maxLevel);
  if (!l) throw std::invalid_argument(l.error());
  if ((*l)->grid.numLevels() == slot.current->grid.numLevels() && time == slot.current->time) {
    m.freeLayer(**l); // the same levels (the limit lies past the layer's own): nothing to swap
    return;
  }
  slot.pending = std::move(*l);
}

void Renderer::moveLayer(std::size_t from, std::size_t to) {
  Impl& m = *impl_;
  if (from == 0 || to == 0 || from >= m.layers.size() || to >= m.layers.size())
    throw std::invalid_argument("only overlays (layers 1 and up) move");
  if (from < to)
    std::rotate(m.layers.begin() + static_cast<std::ptrdiff_t>(from),
                m.layers.begin() + static_cast<std::ptrdiff_t>(from) + 1,
                m.layers.begin() + static_cast<std::ptrdiff_t>(to) + 1);
  else if (from > to)
    std::rotate(m.layers.begin() + static_cast<std::ptrdiff_t>(to),
                m.layers.begin() + static_cast<std::ptrdiff_t>(from),
                m.layers.begin() + static_cast<std::ptrdiff_t>(from) + 1);
}

void Renderer::setLayerTime(std::size_t layer, std::string time) {
  Impl& m = *impl_;
  if (layer >= m.layers.size()) throw std::invalid_argument("no such layer");
  LayerSlot& slot = m.layers[layer];
  if (slot.pending && slot.pending->time == time) return;
  if (m.window != nullptr) glfwMakeContextCurrent(m.window);
  if (slot.pending) { // replaced, or cancelled by going back to the current time
    slot.retiredRequested += slot.pending->streamer->stats().requested;
    slot.retiredReceived += slot.pending->streamer->stats().received;
    m.freeLayer(*slot.pending);
    slot.pending.reset();
  }
  slot.opt.time = time;
  if (time == slot.current->time && slot.current->grid.numLevels() == m.levelsFor(slot)) return;
  auto l = m.makeLayer(slot.opt.layer, time, layer > 0, slot.opt.maxLevel);
  if (!l) throw std::invalid_argument(l.error());
  slot.pending = std::move(*l);
}

bool Renderer::complete() const noexcept {
  return impl_->lastComplete;
}

bool Renderer::busy() const noexcept {
  const Impl& m = *impl_;
  for (const LayerSlot& slot : m.layers)
    for (const LayerTextures* l : {slot.current.get(), slot.pending.get()})
      if (l != nullptr && !l->idle()) return true;
  return !m.uploads.empty() || m.decoder.pending() > 0 || (m.heights && m.heights->busy());
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
  if (m.dome) { // faces for the new size (kept when that fails: the old ones still draw)
    const int n = std::min(width, height);
    auto made = Dome::create(std::max(8, static_cast<int>(std::lround(m.opt.dome->faceScale * n))),
                             m.gl45 ? "#version 450 core\n" : "#version 330 core\n",
                             m.opt.dome->method == DomeMethod::Cube || m.dome->facesAllocated());
    if (made) m.dome = std::move(*made);
  }
}

} // namespace tellus::planet
