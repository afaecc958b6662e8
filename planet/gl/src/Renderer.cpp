// The GL layer of the planet renderer: see Renderer.hpp, RendererImpl.hpp (the frame's phases and
// where each lives) and docs/design/renderer.md. Every GL call here runs on
// the thread that created the Renderer.

#include "AtmospherePass.hpp"
#include "BodiesPass.hpp"
#include "DrawList.hpp"
#include "FrameUpdate.hpp"
#include "GlobePass.hpp"
#include "LayerAnimation.hpp"
#include "RendererImpl.hpp"
#include "StarsPass.hpp"
#include "TextureIntake.hpp"
#include "ValueTexture.hpp"

#include <tellus/planet/Morph.hpp>
#include <tellus/planet/TextureFallback.hpp>

#include <epoxy/gl.h>
// epoxy first: GLFW must not include a GL header of its own.
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

namespace tellus::planet {

namespace {

using SteadyClock = std::chrono::steady_clock;

double msSince(SteadyClock::time_point t) {
  return std::chrono::duration<double, std::milli>(SteadyClock::now() - t).count();
}

/** Milliseconds since the last call (or since it was made). */
class Lap {
public:
  double operator()() {
    const auto now = SteadyClock::now();
    const double ms = std::chrono::duration<double, std::milli>(now - last_).count();
    last_ = now;
    return ms;
  }

private:
  SteadyClock::time_point last_ = SteadyClock::now();
};

std::optional<std::string> invalidOptions(const RendererOptions& o) {
  if (o.width <= 0 || o.height <= 0 || o.width > 16384 || o.height > 16384)
    return "the image size must be 1 to 16384 pixels each way";
  if (const auto& p = o.projectorWarp;
      p && (p->width < 0 || p->height < 0 || p->width > 16384 || p->height > 16384 ||
            (p->width == 0) != (p->height == 0)))
    return "the projector's size must be 1 to 16384 pixels each way (or 0 x 0: the image's)";
  if (!(o.lodThreshold > 0.0) || !std::isfinite(o.lodThreshold))
    return "the LOD threshold must be a positive number";
  const int n = o.meshSize;
  if (n < 3 || n > 1025 || ((n - 1) & (n - 2)) != 0)
    return "the mesh size must be 2^k + 1 (3 to 1025)";
  if (!std::isfinite(o.starMagnitudeLimit))
    return "the stars' magnitude limit must be a finite number";
  if (!(o.starBrightness >= 0.0) || !std::isfinite(o.starBrightness))
    return "the stars' brightness must be a finite number >= 0";
  return std::nullopt;
}

} // namespace

Renderer::Impl::Impl(ITileSource& s, const Geodesy& g, RendererOptions o, TileGrid baseGrid)
    : source(s), geodesy(g), opt(std::move(o)), terrain(opt), layers(s, g, opt, baseGrid),
      decoder(opt.decodeThreads, opt.decodeNice, opt.imageDecoder),
      pacer(UploadPacing{.bytesPerFrame = opt.uploadBytesPerFrame,
                         .shareOfFrame = opt.uploadShareOfFrame}) {
  layers.setPrepare([this](LayerTextures& l) { terrain.applyTo(*l.tree, l.chordDepthM); });
}

Renderer::Impl::~Impl() {
  if (context) context->makeCurrent();
}

std::string Renderer::Impl::openGl() {
  if (opt.shareWindowOf != nullptr) { // another body's renderer's window (issue 26)
    context = opt.shareWindowOf->impl_->context;
    context->makeCurrent();
  } else {
    const bool projectorSize = opt.projectorWarp && opt.projectorWarp->width > 0;
    auto made = GlContext::create({.visible = opt.visibleWindow,
                                   .width = projectorSize ? opt.projectorWarp->width : opt.width,
                                   .height = projectorSize ? opt.projectorWarp->height : opt.height,
                                   .title = opt.windowTitle,
                                   .vsync = opt.vsync});
    if (!made) return made.error();
    context = std::move(*made);
  }
  const GlCapabilities& gl = context->capabilities();
  stats.reversedZ = gl.clipControl;
  stats.glVersion = gl.version;
  textureFormat.storage = gl.textureStorage;
  if (opt.anisotropy > 1.0)
    textureFormat.anisotropy = std::min(static_cast<float>(opt.anisotropy), gl.maxAnisotropy);
  meshes = std::make_unique<NodeMeshes>(
      geodesy, terrain, opt.meshSize, opt.fixEdges, gl.gl45 && opt.fp64Vertices, opt.geomorph);
  auto globe = GlobePass::create(gl,
                                 {.fp64 = opt.fp64Vertices,
                                  .fisheye = opt.dome && opt.dome->method == DomeMethod::Direct,
                                  .overlaysPerPass = opt.overlaysPerPass},
                                 *meshes);
  if (!globe) return globe.error();
  stats.overlaysPerPass = (*globe)->overlaysPerPass();
  globePass = globe->get();
  globePass->setCullBackFaces(opt.cullBackFaces);
  scene = std::make_unique<SceneDraw>(opt, geodesy, gl);
  if (opt.stars) { // behind everything: before the globe (ScenePass.hpp)
    auto stars = StarsPass::create(gl,
                                   *opt.stars,
                                   {.fisheye = opt.dome && opt.dome->method == DomeMethod::Direct,
                                    .magnitudeLimit = opt.starMagnitudeLimit,
                                    .brightness = opt.starBrightness});
    if (!stars) return stars.error();
    scene->addPass(std::move(*stars));
  }
  scene->addPass(std::move(*globe));
  if (!opt.sceneBodies.empty()) { // after the globe, under its air (BodiesPass.hpp)
    const auto frameBody = sceneBodyOf(geodesy.body());
    if (!frameBody)
      return "body '" + geodesy.body().name + "' has no ephemeris: no other body can join it";
    auto bodies = BodiesPass::create(
        gl, opt.dome && opt.dome->method == DomeMethod::Direct, *frameBody, opt.sceneBodies);
    if (!bodies) return bodies.error();
    scene->addPass(std::move(*bodies));
  }
  if (opt.atmosphere) {
    auto air = AtmospherePass::create(gl,
                                      opt.atmosphere->parameters,
                                      opt.atmosphere->exposure,
                                      geodesy,
                                      opt.atmosphere->tableCacheDir,
                                      opt.atmosphere->resolutionDivisor);
    if (!air) return air.error();
    stats.atmospherePrecomputeMs = (*air)->precomputeSeconds() * 1000.0;
    scene->addPass(std::move(*air));
  }
  if (opt.projectorWarp) {
    const RendererOptions::ProjectorCalibration& p = *opt.projectorWarp;
    auto made = ProjectorWarp::create(gl.glslHeader(),
                                      opt.width,
                                      opt.height,
                                      p.width > 0 ? p.width : opt.width,
                                      p.height > 0 ? p.height : opt.height,
                                      p.mesh,
                                      p.blend);
    if (!made) return made.error();
    projector = std::move(*made);
  }
  globalTexture = makeGlobalTexture(opt.globalImage);
  if (glGetError() != GL_NO_ERROR) return "OpenGL error while setting up";
  return {};
}

std::expected<std::unique_ptr<Renderer>, std::string>
Renderer::create(ITileSource& source, const Geodesy& geodesy, RendererOptions options) {
  if (const auto invalid = invalidOptions(options)) return std::unexpected(*invalid);
  const auto spec = source.describe(options.layer, options.time);
  if (!spec) return std::unexpected("unknown layer '" + options.layer + "'");
  auto grid = TileGrid::create(spec->grid);
  if (!grid) return std::unexpected("layer '" + options.layer + "': " + grid.error());
  for (const LayerOptions& l : options.overlays)
    if (!(l.opacity >= 0.0 && l.opacity <= 1.0))
      return std::unexpected("overlay '" + l.layer + "': the opacity must be in [0, 1]");
  // The body decides the sky (issue 26): none on an airless body, its own air on any other than
  // the Earth (whose parameters the options may tune); and the relief bound covers its mountains.
  const Body& body = geodesy.body();
  if (options.atmosphere && !body.atmosphere) options.atmosphere.reset();
  if (options.atmosphere && body.name != "earth") options.atmosphere->parameters = *body.atmosphere;
  options.terrainReliefBoundM = std::max(options.terrainReliefBoundM, body.reliefBoundM);
  auto impl = std::make_unique<Impl>(source, geodesy, std::move(options), *grid);
  if (auto err = impl->openGl(); !err.empty()) return std::unexpected(err);
  if (auto opened = impl->layers.open(); !opened) return std::unexpected(opened.error());
  if (!impl->opt.overviewLayer.empty()) {
    const GridSpec& g = grid->spec();
    auto o = Overview::start(
        source, impl->opt.overviewLayer, impl->opt.time, g.levelZeroDeltaDeg / g.tileWidth);
    if (!o) return std::unexpected(o.error());
    impl->overview = std::move(*o);
  }
  if (!impl->opt.elevationLayer.empty()) {
    if (auto opened = impl->terrain.open(source); !opened) return std::unexpected(opened.error());
    for (LayerSlot& l : impl->layers.slots())
      impl->terrain.applyTo(*l.current->tree, l.current->chordDepthM);
  }
  if (auto opened = impl->scene->openDome(); !opened) return std::unexpected(opened.error());
  impl->warmUp();
  return std::unique_ptr<Renderer>(new Renderer(std::move(impl)));
}

// One untimed frame before the first real one, so that no frame pays for first use: the driver
// compiles the program's variants for both kinds of texture (llvmpipe does so at the first draw,
// 0.3-0.6 s without Mesa's shader cache), and every GL entry point the frame loop calls is resolved
// (libepoxy looks each one up on its first call; with the tile service dlopen()ing its imaging
// module on a worker at the same time, such a lookup waited 0.3-0.9 s for the loader's lock).
// Draws into the framebuffer, which the first frame clears; leaves nothing behind.
void Renderer::Impl::warmUp() {
  const Node* root = nullptr;
  for (const auto& r : layers.geo().roots())
    if (r && !r->isCap() && root == nullptr) root = r.get();
  if (root == nullptr) return;
  const RenderStats before = stats; // the warm-up counts no mesh, upload or texture
  const LayerTextures& base = layers.base();
  const GlTexture texture = makeNodeTexture(base.texWidth, base.texHeight, textureFormat);
  const std::uint8_t texel[4] = {0, 0, 0, 255};
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexSubImage2D(GL_TEXTURE_2D, base.texLevels - 1, 0, 0, 1, 1, GL_RGBA, GL_UNSIGNED_BYTE, texel);
  DrawList list;
  list.parts.push_back({.node = root, .texture = &globalTexture, .uv = globalUv(root->sector())});
  list.parts.push_back({.node = root, .texture = &texture, .uv = UvTransform{}});
  if (layers.size() > 1) { // the program with overlays, and a second pass
    const auto n = static_cast<std::uint32_t>(stats.overlaysPerPass + 1);
    for (std::uint32_t i = 0; i < n; ++i)
      list.bindings.push_back({&texture, UvTransform{}, 0.0f, false, std::nullopt});
    list.parts.back().overlayEnd = n;
  }
  const Camera cam(geodesy, CameraPose{}, {opt.width, opt.height}, opt.verticalFovDeg);
  meshes->beginFrame(layers.geo().frame(), stats.frames);
  const SceneFramebuffer& fb = scene->framebuffer();
  scene->drawScene(cam, {fb.id(), fb.width(), fb.height(), nullptr}, list, stats, false);
  glFinish();
  meshes->erase(root->key());
  stats = before;
}

Renderer::Renderer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Renderer::~Renderer() = default;

double Renderer::Impl::surfaceHeightAt(double latDeg, double lonDeg) const {
  if (layers.size() == 0) return terrain.heightAt(latDeg, lonDeg);
  return meshes->surfaceHeightAt(latDeg, lonDeg, layers.geo().drawList());
}

CameraPose Renderer::Impl::clampToTerrain(const CameraPose& pose) const {
  CameraPose p = pose;
  if (!terrain.enabled() || !std::isfinite(pose.latDeg) || !std::isfinite(pose.lonDeg)) return p;
  const double floor = surfaceHeightAt(pose.latDeg, pose.lonDeg) + opt.terrainClearanceM;
  if (p.altitudeM < floor) p.altitudeM = floor;
  return p;
}

Camera Renderer::Impl::cameraFor(const CameraPose& pose) const {
  // A low camera needs a nearer near plane than 0.1 m; its height above the ground below it
  // (the terrain when heights are loaded) decides (docs/ACCURACY.md, numerical stability).
  double above = pose.altitudeM;
  if (std::isfinite(pose.latDeg) && std::isfinite(pose.lonDeg)) {
    const double ground = terrain.heightAt(pose.latDeg, pose.lonDeg);
    if (std::isfinite(ground)) above -= ground;
  }
  const double aspect = static_cast<double>(opt.width) / static_cast<double>(opt.height);
  if (opt.dome) // the faces' near plane: 90-degree square views
    return Camera(geodesy,
                  pose,
                  std::min(opt.width, opt.height),
                  Fisheye{opt.dome->fovDeg, opt.dome->tiltDeg},
                  nearDistanceFor(above, 90.0, 1.0));
  const double nearM = nearDistanceFor(above, opt.verticalFovDeg, aspect);
  if (opt.channelView) { // a dome's projector channel: its direction in the dome's frame
    const Camera dome(geodesy, pose, 2, Fisheye{180.0, opt.channelView->domeTiltDeg}, nearM);
    const auto world = [&](const glm::dvec3& d) {
      return d.x * dome.right() + d.y * dome.up() - d.z * dome.forward();
    };
    return Camera(dome,
                  world(opt.channelView->forward),
                  world(opt.channelView->up),
                  {opt.width, opt.height},
                  opt.verticalFovDeg,
                  &geodesy);
  }
  return Camera(geodesy, pose, {opt.width, opt.height}, opt.verticalFovDeg, nearM);
}

Renderer::Impl::View Renderer::Impl::beginFrame(const CameraPose& pose) {
  terrain.deliver(layers);
  const CameraPose safe = clampToTerrain(pose);
  stats.cameraLifted = safe.altitudeM != pose.altitudeM;
  drawnPose = safe;
  View view{safe, cameraFor(safe)};
  terrain.chooseRelief(view.camera, view.pose.altitudeM, layers);
  stats.meshesBuiltLast = 0;
  stats.meshMs = 0.0;
  context->makeCurrent();
  ++stats.frames;
  return view;
}

// Meshes before drawing (a node's mesh depends on which neighbours are drawn, known only now);
// then the camera once more above the surface they make (the tree may have split under it).
void Renderer::Impl::buildMeshes(View& view) {
  meshes->beginFrame(layers.geo().frame(), stats.frames);
  meshes->buildFor(layers.geo().drawList(), stats);
  if (const CameraPose again = clampToTerrain(view.pose); again.altitudeM != view.pose.altitudeM) {
    view.pose = again;
    view.camera = cameraFor(view.pose);
    stats.cameraLifted = true;
    drawnPose = view.pose;
  }
}

void Renderer::Impl::draw(const Camera& camera, const DrawList& list) {
  const Quadtree& geo = layers.geo();
  if (opt.geomorph) { // the LOD's camera: the morph is the same on every cube face of a dome
    const double focalPx =
        camera.isFisheye() ? camera.pixelsPerRadian()
                           : 0.5 * static_cast<double>(camera.viewport().height) /
                                 std::tan(0.5 * camera.verticalFovDeg() * std::numbers::pi / 180.0);
    globePass->setMorphScale(morphScale(focalPx, opt.lodThreshold, layers.base().texHeight));
  }
  scene->drawFrame(camera,
                   list,
                   geo.drawList(),
                   terrain.heightAt(camera.pose().latDeg, camera.pose().lonDeg),
                   stats);
  if (opt.legend) drawLegends();
  if (projector) projector->apply(scene->framebuffer().id());
  if (opt.visibleWindow && !opt.presentOnRequest) present();
}

void Renderer::Impl::drawLegends() {
  std::vector<LegendEntry> entries;
  for (const LayerSlot& slot : layers.slots()) {
    if (!slot.opt.values || !slot.opt.visible || !(slot.opt.opacity > 0.0)) continue;
    const ValueLayerOptions& v = *slot.opt.values;
    entries.push_back({colourScaleFor(v, slot.dataRange),
                       v.format.unit,
                       v.title.empty() ? slot.opt.layer : v.title});
  }
  if (entries.empty()) return;
  const SceneFramebuffer& fb = scene->framebuffer();
  legends.draw(entries, fb.id(), fb.width(), fb.height(), opt.dome.has_value());
}

void Renderer::Impl::houseKeeping() {
  if (stats.frames % 64 == 0) {
    layers.forEach([&](LayerTextures& l) { dropStaleTiles(l, stats.frames); });
    meshes->sweep();
  }
  if (opt.visibleWindow) glfwPollEvents();
}

void Renderer::Impl::endFrame(const FrameStats& tree,
                              bool complete,
                              FramePhases& phases,
                              SteadyClock::time_point t0) {
  layers.swapReady();
  observeAnimations(layers, frameS);
  const LayerTotals totals = layers.collectStats(stats);
  lastComplete =
      complete && totals.idle && uploads.empty() && decoder.pending() == 0 && !terrain.busy();
  RenderStats& s = stats;
  s.nodesVisible = tree.visible;
  s.nodesDrawn = tree.drawn;
  s.nodesCreated = tree.created;
  s.nodesCreatedTotal += tree.created;
  s.nodesInTree = tree.nodes;
  s.maxLevel = tree.maxLevel;
  s.tilesRequested = totals.stream.requested;
  s.tilesReceived = totals.stream.received;
  s.tilesAbsent = totals.stream.absent;
  s.tilesFailed = totals.stream.failed;
  s.tilesInFlight = totals.stream.inFlight;
  s.decodesPending = decoder.pending();
  s.uploadsPending = uploads.size();
  s.sceneTimeUnixSeconds = opt.timeUnixSeconds;
  s.sunlight = opt.sunLatLon.has_value() || (opt.sunlight && opt.timeUnixSeconds.has_value());
  s.frameMs = msSince(t0);
  phases.total = s.frameMs;
  s.phases = phases;
  pacer.recordFrame(phases.total, phases.upload);
}

// The frame: its phases in order (RendererImpl.hpp), each timed into RenderStats::phases.
void Renderer::frame(const CameraPose& pose) {
  Impl& m = *impl_;
  const auto t0 = SteadyClock::now();
  const double nowS = std::chrono::duration<double>(t0 - m.start).count();
  const double frameS = m.opt.frameClock ? m.opt.frameClock() : nowS; // fades' time
  m.frameS = frameS;
  m.terrain.setTime(frameS); // before the heights delivered this frame (beginFrame) arrive
  Impl::View view = m.beginFrame(pose);
  stepAnimations(m.layers, frameS); // time that plays: the instants asked for (issue 24)
  if (m.overview) applyOverview(*m.overview, m.globalTexture, m.layers.base());
  // A copy: the tree it comes from may be swapped out at the end of this frame (a time change).
  const FrameStats tree = updateLayers(m.layers, view.camera, nowS);
  if (m.overview) overviewUnder(*m.overview, m.layers.base());
  fetchAhead(m.layers);
  m.terrain.want(m.layers.geo(), nowS, m.stats);
  m.stats.updateMs = msSince(t0);
  m.stats.longestUpdateMs = std::max(m.stats.longestUpdateMs, m.stats.updateMs);
  FramePhases ph;
  ph.update = m.stats.updateMs;
  Lap lap;
  intakeTextures(m.layers, m.decoder, m.uploads, m.stats);
  ph.intake = lap();
  // What this frame draws, and the LRU told so before anything new is inserted.
  updateDataRanges(m.layers); // `range: data` of layers of values (issue 24)
  DrawList list = planDraw(m.layers, m.globalTexture, m.stats, frameS, m.opt.fadeInSeconds);
  // A fade in progress is not the settled image (RendererOptions::fadeInSeconds).
  const bool complete = !list.fading && drawsWhatLodAsks(m.layers, tree, [&m](const Node& n) {
    return m.terrain.complete(n);
  });
  (void)lap();
  const std::size_t uploadedBefore = m.stats.bytesUploaded;
  m.uploads.step(m.layers, m.pacer, m.textureFormat, m.stats);
  ph.upload = lap();
  ph.uploadBytes = m.stats.bytesUploaded - uploadedBefore;
  m.layers.forEach([&m](LayerTextures& l) { m.stats.texturesEvicted += l.evict(); });
  (void)lap();
  const std::size_t meshesBefore = m.stats.meshesBuilt;
  m.buildMeshes(view);
  ph.meshesCreated = m.stats.meshesBuilt - meshesBefore;
  ph.mesh = lap();
  m.draw(view.camera, list);
  ph.draw = lap();
  m.houseKeeping();
  (void)lap();
  glFinish();
  ph.finish = lap();
  std::size_t swaps = 0;
  for (std::size_t i = 0; i < m.layers.size(); ++i)
    swaps += m.layers[i].swaps;
  m.endFrame(tree, complete, ph, t0);
  std::size_t swapsAfter = 0;
  for (std::size_t i = 0; i < m.layers.size(); ++i)
    swapsAfter += m.layers[i].swaps;
  if (swapsAfter == swaps)
    m.lastList = std::move(list);
  else
    m.lastList.reset(); // a tree swapped out: the list points into it
}

// Nothing of the state changes: no terrain delivery, update, intake, upload or mesh build.
void Renderer::redrawLast(const CameraPose& pose) {
  Impl& m = *impl_;
  if (!m.lastList) return;
  m.context->makeCurrent();
  const Camera camera = m.cameraFor(m.clampToTerrain(pose));
  m.globePass->setCullBackFaces(true); // what the last frame culled stays background
  m.draw(camera, *m.lastList);
  m.globePass->setCullBackFaces(m.opt.cullBackFaces);
  glDisable(GL_CULL_FACE);
  glFinish();
}

CameraPose Renderer::clampToTerrain(const CameraPose& pose) const {
  return impl_->clampToTerrain(pose);
}
Camera Renderer::camera(const CameraPose& pose) const {
  return impl_->cameraFor(pose);
}
CameraPose Renderer::drawnPose() const {
  return impl_->drawnPose;
}
double Renderer::terrainHeight(double latDeg, double lonDeg) const {
  return impl_->terrain.heightAt(latDeg, lonDeg);
}
const Geodesy& Renderer::geodesy() const noexcept {
  return impl_->geodesy;
}
bool Renderer::complete() const noexcept {
  return impl_->lastComplete;
}
bool Renderer::busy() const noexcept {
  const Impl& m = *impl_;
  return !m.layers.idle() || !m.uploads.empty() || m.decoder.pending() > 0 || m.terrain.busy();
}
std::vector<std::uint8_t> Renderer::readPixels() const {
  impl_->context->makeCurrent();
  return impl_->scene->framebuffer().readPixels();
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
  return glfwWindowShouldClose(impl_->context->window()) == GLFW_TRUE;
}
void* Renderer::nativeWindow() const noexcept {
  return impl_->opt.visibleWindow ? impl_->context->window() : nullptr;
}
void Renderer::setOverlayText(std::string text) {
  impl_->presenter.setText(std::move(text));
}

void Renderer::setTime(std::optional<double> unixSeconds) {
  impl_->opt.timeUnixSeconds = unixSeconds;
}
std::optional<double> Renderer::time() const noexcept {
  return impl_->stats.sceneTimeUnixSeconds;
}

void Renderer::resize(int width, int height) {
  Impl& m = *impl_;
  if (width <= 0 || height <= 0 || (width == m.opt.width && height == m.opt.height) || m.projector)
    return;
  m.context->makeCurrent();
  m.opt.width = width;
  m.opt.height = height;
  m.scene->resize();
}

} // namespace tellus::planet
