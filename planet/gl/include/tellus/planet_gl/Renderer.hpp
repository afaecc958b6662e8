#pragma once
/**
 * @file Renderer.hpp
 * @brief The planet renderer's GL layer: an OpenGL context (GLFW, hidden window for headless use),
 * an offscreen framebuffer with a 32-bit float reversed-Z depth buffer, node meshes drawn with
 * camera-relative matrices, and texture streaming (decoding on worker threads, banded uploads under
 * a per-frame byte and time budget, a reusable texture pool, the LRU). No GL type appears here: GL,
 * GLFW and libepoxy are private to tellus::planet_gl (JPEG and PNG through tellus::codec).
 *
 * One Renderer draws a base layer and its overlays. Both a window loop (`tellus view`) and the
 * headless loop (`tellus render`) call frame(pose) once per frame; readPixels() reads the last
 * frame back.
 * Threads: every method belongs to the thread that created the Renderer (it owns the GL context).
 *
 * Inside (planet/gl/src/RendererImpl.hpp), frame() is a sequence of phases, one unit each (update,
 * intake, plan, upload, mesh, draw), and its draw phase an ordered list of scene passes
 * (ScenePass.hpp): the place for the atmosphere, sun and stars (issue 23). The body drawn is the
 * Geodesy given to create(), made from a planet::Body (issue 26, docs/design/bodies.md): the body
 * decides the sky (none without an atmosphere), the sun (the Earth's from Astronomy; other bodies'
 * from their ephemeris) and the relief bound.
 */

#include <tellus/cache/TileSource.hpp>
#include <tellus/planet/Atmosphere.hpp>
#include <tellus/planet/Camera.hpp>
#include <tellus/planet/ChannelWarp.hpp>
#include <tellus/planet/Geodesy.hpp>
#include <tellus/planet/HeightStreamer.hpp>
#include <tellus/planet/StarCatalogue.hpp>
#include <tellus/planet/Terrain.hpp>
#include <tellus/planet/TimeAnimation.hpp>
#include <tellus/values/ColourScale.hpp>
#include <tellus/values/ValueFormat.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace tellus::planet {

class Renderer;

/** 8-bit RGBA pixels, rows from the top (decoded images, readImageFile). */
struct RgbaImage {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> pixels;
};

/** Decodes an imagery tile that is neither JPEG nor PNG (the renderer reads those itself, with
 * the codec module): its bytes, the content type the tile source gave, and the layer's
 * tile size. Runs on the decoder threads, several at once: it must be thread safe. */
using ImageDecoder = std::function<std::expected<RgbaImage, std::string>(
    std::span<const std::byte> bytes, std::string_view contentType, int width, int height)>;

/** A layer of values (issue 24): its tiles are raw samples (values::decode: BIL, TIFF, 16-bit
 * PNG) that the renderer keeps as one float per texel (an R32F texture, exact: no rounding of the
 * values on the GPU) and colours in the shader with the EXACT rule of values/ColourScale.hpp
 * (t in float, index = clamp(floor(t * 256), 0, 255), the map's entry; no data and, with
 * OutOfRange::Transparent, values outside the range transparent: the layers below show).
 * Sampling: values/Sample.hpp, the proxy's GetMap's rule (four texelFetch, no GL filtering):
 * bilinear of the values, then the colour; beside no data the point's own texel. A render and a
 * GetMap agree within one colour entry but in the half texel along a tile's edge, where a node's
 * texture has no neighbour texels and is clamped (docs/design/values-renderer.md). */
struct ValueLayerOptions {
  values::ValueFormat format; ///< how the tiles' raw samples become values (unit included)
  std::string colourMap{values::kDefaultColourMap}; ///< a values::colourMaps() name
  double min = 0.0; ///< the range (a fixed one, or the fallback of rangeFromData)
  double max = 1.0;
  values::Scaling scaling = values::Scaling::Linear;
  values::OutOfRange outOfRange = values::OutOfRange::Clamp;
  /** The range from the values drawn (`range: data`): the lowPercent and highPercent
   * percentiles of a bounded sample (at most kDataRangeSample values a texture) of the textures
   * the layer's visible nodes show, recomputed each frame; min/max until a texture is there. */
  bool rangeFromData = false;
  double lowPercent = 0.0;
  double highPercent = 100.0;
  std::string title; ///< for the legend ("" = the layer's name)
  static constexpr std::size_t kDataRangeSample = 256;
};

/** An imagery layer drawn over the base imagery (issue #7): sea-surface temperature, night lights,
 * clouds. Its tiles must share the base layer's level-zero tile size (a key is the same sector in
 * both); their pixel size may differ. Transparent texels (PNG alpha) and absent tiles show what
 * lies under the layer. */
struct LayerOptions {
  std::string layer;    ///< of the tile source
  std::string time;     ///< "" = the layer's default time
  double opacity = 1.0; ///< [0, 1], times the texels' own alpha
  bool visible = true;
  int maxLevel = -1; ///< the deepest level fetched and drawn (-1: the layer's own deepest)
  /** A night layer (issue 23, `renderer.layers[i].night`): shown on the dark side only, added
   * as light (it is not lit by the sun) with a weight that goes from 0 with the sun at the
   * horizon to 1 with the sun 6 degrees below it (civil dusk), by the sun's elevation over the
   * ellipsoid at the point, as Uniview and OpenSpace blend their night textures. Hidden when the
   * globe is unlit (no sunlight, no sunLatLon). */
  bool night = false;
  /** A layer of values coloured by the renderer (ValueLayerOptions); nullopt: imagery. An
   * overlay only (the base is opaque imagery). */
  std::optional<ValueLayerOptions> values{};
};

/** How the dome is drawn (issue #7; docs/design/dome.md). */
enum class DomeMethod {
  /** One pass: the node shader maps each vertex through the fisheye itself (straight triangle
   * edges: an approximation, DomeDirect.hpp); a frame whose estimated error exceeds
   * DomeOptions::directMaxErrorPx is drawn with Cube instead. */
  Direct,
  /** Up to five cube faces of faceScale x N, then a warp pass into the fisheye. */
  Cube,
};

/** The dome (issue #7): an angular fisheye domemaster instead of a perspective view. */
struct DomeOptions {
  double fovDeg = 180.0;   ///< (0, 220]
  double tiltDeg = 0.0;    ///< the dome's axis turned up from the pose's view direction
  double faceScale = 0.64; ///< cube faces of faceScale x the image's size (2/pi matches the centre)
  DomeMethod method = DomeMethod::Direct;
  /** Direct: the largest estimated straight-edge error (fisheye pixels) a frame may have before it
   * is drawn with the cube method (directChordErrorPx, DomeDirect.hpp). */
  double directMaxErrorPx = 0.5;
};

struct RendererOptions {
  int width = 1024; ///< framebuffer size in pixels
  int height = 768;
  std::string layer; ///< the base imagery layer asked of the tile source (opaque)
  std::string time;
  /** Imagery layers over the base, drawn in this order (the last on top). */
  std::vector<LayerOptions> overlays;
  /** Overlay textures blended in one pass with the base (0: as many as the GL's texture units
   * allow, at most 8). Past it the node is drawn again (depth equal, blended) with the next ones;
   * 1 draws each overlay in a pass of its own (tests compare both paths). */
  int overlaysPerPass = 0;
  /** An equirectangular JPEG/PNG of the whole globe (north up, -180 at the left), the always
   * resident global texture. Empty or unreadable: a flat dark blue. */
  std::filesystem::path globalImage;
  /** A layer of the base imagery's whole globe on a coarser grid (e.g. 90-degree level-zero
   * tiles of 512 px), or empty: its level-zero tiles, fetched at the start, become the global
   * texture (instead of globalImage), and a level-zero node whose texels it shows within the
   * LOD threshold is drawn with it, its own tiles not fetched (issue 29). */
  std::string overviewLayer;
  std::array<double, 3> background{0.0, 0.0, 0.0}; ///< RGB in [0, 1]
  double lodThreshold = 1.0;                       ///< texel-to-pixel threshold (> 0)
  /** Anisotropic filtering of node textures (sharper tilted views; 1 = off; capped by the GL).
   * Off by default: on llvmpipe 8x cost 1.5-2x the frame time of a tilted view. */
  double anisotropy = 1.0;
  int meshSize = 33; ///< N of the N x N node grid (2^k + 1)
  double verticalFovDeg = 45.0;
  std::size_t textureBudgetBytes = std::size_t{768} << 20; ///< the LRU's budget
  std::size_t uploadBytesPerFrame = std::size_t{8} << 20;  ///< banded uploads per frame
  /** Upload time a frame may spend, as a share of the recent median frame time without uploads
   * (at least 0.5 ms and one band a frame); 0: bytes alone limit uploads. */
  double uploadShareOfFrame = 0.25;
  std::size_t maxInFlight = 16; ///< tile requests out at once
  int maxSplitsPerFrame = 64;
  int decodeThreads = 2;
  /** Imagery tiles in other formats than JPEG and PNG (a layer of `format: image/tiff`); empty:
   * they are undecodable and their nodes fall back. `tellus` passes the proxy's decodeImagery,
   * which reads TIFF through the imaging module (OpenImageIO), as `serve` does for its maps. */
  ImageDecoder imageDecoder;
  /** Terrain (issue #6): the elevation layer asked of the tile source ("" = none: the bare
   * ellipsoid), its time, and how its raw samples become metres. */
  std::string elevationLayer;
  std::string elevationTime;
  HeightEncoding elevationEncoding{};
  /** Decodes the elevation layer's tiles (on the tile source's threads); empty: the built-in
   * decodeHeightTile (BIL16, 16-bit PNG). `tellus` passes the proxy's decoder, which also reads
   * Int16 TIFF through the imaging module. */
  HeightDecoder heightDecoder;
  /** The elevation layer's heights are above mean sea level and moved onto the ellipsoid with
   * this (h = H + N, once per tile on the worker that decodes it; `renderer.geoid`); default off:
   * heights taken as ellipsoid heights. The exaggeration multiplies h. */
  VerticalDatum verticalDatum;
  double verticalExaggeration = 1.0; ///< heights are multiplied by this (> 0)
  double terrainClearanceM = 2.0;    ///< the camera is kept this far above the terrain
  /** "Model only what a scene requires" (issue #8): a frame fetches and draws heights only when
   * the largest relief the data can have (terrainReliefBoundM x the exaggeration, or the lowest
   * height held if deeper) could move the nearest surface point by at least this many pixels
   * (the view's focal length, or the dome's pixels per radian, over the altitude less that
   * relief); below that it draws the bare ellipsoid. A function of the camera alone, so a frame
   * does not depend on what earlier frames loaded. 0: heights always. */
  double terrainMinReliefPx = 0.5;
  /** |height| bound for that test (Everest 8,849 m, +N); create() raises it to the body's
   * Body::reliefBoundM (Mars: 26 km). */
  double terrainReliefBoundM = 11000.0;
  /** Edge fixing (finer edges onto coarser chords, zero-area triangles). Off only to measure what
   * it costs and what it prevents (benchmarks, the test that shows the cracks it closes). */
  bool fixEdges = true;
  /** Diagnostic (tests): every frame drawn with back faces culled, as Renderer::redrawLast
   * draws. The surface seen from outside is front faces only, so nothing that belongs may vanish,
   * and a crack shows the background (the globe's inside is culled), which a test can count. */
  bool cullBackFaces = false;
  /** Vertex positions as doubles on the GPU (OpenGL 4.x), made eye-relative by one double
   * subtraction. Off, or on a 3.3 context: two floats per coordinate (high + low), the eye's
   * pair subtracted in float (GpuVertex.hpp; as precise as doubles at the views measured,
   * docs/ACCURACY.md "The trade"). */
  bool fp64Vertices = true;
  /** Sunlight (as `sunlight` below) with the sun overhead at this latitude and longitude
   * (degrees), whatever the time and `sunlight` say; nullopt: the sun of timeUnixSeconds when
   * `sunlight`, else unlit (the imagery's own colours). */
  std::optional<std::array<double, 2>> sunLatLon;
  /** The scene's time, UTC as POSIX seconds (planet/Astronomy.hpp): the sun's direction (when
   * sunLatLon is not given) and the sky's rotation; nullopt: no time (unlit unless sunLatLon,
   * the sky unrotated). Renderer::setTime changes it from frame to frame. */
  std::optional<double> timeUnixSeconds;
  /** Sunlight on the globe (issue 23): the day side lit by the sun of timeUnixSeconds (or
   * sunLatLon) over the relief's normals, the night side dark (a little ambient light, and the
   * night layers), a soft terminator by the sun's elevation (shaders/planet.frag). Off: the
   * imagery's own colours, unless sunLatLon is given (then lit as before). The configuration
   * turns it on (`renderer.sun.enabled`, `--no-sun` off). */
  bool sunlight = false;
  /** The star background (issue 23; StarCatalogue.hpp, drawn by planet/gl/src/StarsPass.hpp
   * before the globe, placed by timeUnixSeconds, J2000.0 without one): null = no stars, the
   * library's default (`tellus` reads the bundled data/stars-hip-6.5.txt when
   * `renderer.stars.enabled`). Stars fainter than starMagnitudeLimit (V) are left out;
   * starBrightness (>= 0) multiplies every star's energy (starEnergy: 1 = Sirius peaks at 0.92 of
   * a full pixel). */
  std::shared_ptr<const StarCatalogue> stars;
  double starMagnitudeLimit = 6.5;
  double starBrightness = 1.0;
  /** The atmosphere (issue 23; planet/Atmosphere.hpp, planet/gl/src/AtmospherePass.hpp): the sky
   * and the aerial perspective, drawn after the globe; nullopt: none (the library's default, so
   * that renderer tests keep their pixels; the configuration turns it on). The body overrides it
   * (create()): an airless body (the Moon) gets no atmosphere pass at all, and a body other than
   * the Earth gets its own parameters (Body::atmosphere) whatever these say. */
  struct Atmosphere {
    AtmosphereParameters parameters; ///< bottomRadiusM <= 0: the body's equatorial radius
    /** The display's scale of radiance (solar units): shown = 1 - exp(-exposure L), gamma 2.2. */
    double exposure = 2.5;
    /** Where the precomputed tables are kept between runs (planet/AtmosphereCache.hpp); empty:
     * computed at every start, nothing written. The CLI: <cache root>/atmosphere. */
    std::string tableCacheDir;
    /** The sky and haze computed at 1 / divisor of the target's width and height, then spread
     * over it (the sun's disc at full resolution): 1 (the default), 2 or 4
     * (AtmospherePass.hpp; the accuracy and time it trades in bench/RESULTS.md). */
    int resolutionDivisor = 1;
  };
  std::optional<Atmosphere> atmosphere;
  /** Added to the decoding threads' nice value: decoding in the background gives the CPU up to
   * the frame (on llvmpipe drawing is CPU work too, and competing decoders made frames 2-5x
   * longer). 0: the process's priority. */
  int decodeNice = 10;
  /** A domemaster (square image: the circle of diameter min(width, height), black around) drawn
   * directly or as cube faces and a warp (DomeOptions::method), with the LOD and culling of the
   * fisheye; nullopt: a perspective. */
  std::optional<DomeOptions> dome;
  /** A projector channel of a dome (issue 28, docs/design/cluster.md): the perspective (this
   * size, verticalFovDeg) looks along `forward` with `up`, given in the dome coordinates of the
   * fisheye camera the pose makes with domeTiltDeg (x its right, y its up, z back: planet/
   * Channels.hpp), instead of along the pose's forward; LOD and culling are the channel's own.
   * Ignored with a dome. nullopt: the pose's own view. */
  struct ChannelView {
    glm::dvec3 forward{0.0, 0.0, -1.0};
    glm::dvec3 up{0.0, 1.0, 0.0};
    double domeTiltDeg = 0.0;
  };
  std::optional<ChannelView> channelView;
  /** No popping (issue 23): a base-layer texture that arrives fades in over this many seconds of
   * frameClock from what was drawn before it (its nearest resident ancestor's texture, else the
   * global one) instead of appearing at once; the frame is not complete() while a fade runs, so a
   * settled image is the same as without fading. 0: off (the library's default; `renderer.fade_in`
   * defaults to 0.3 s). A fade starts at the frame the texture is first drawn (weight 0). */
  double fadeInSeconds = 0.0;
  /** The renderer's frame time in seconds (any origin, never decreasing) for fades; empty: the
   * steady clock. Tests and `tellus render`'s flights inject their own (a flight's time). */
  std::function<double()> frameClock;
  /** Geomorphing (issue 23, thesis 6.2.2): each vertex blends between its position in its own
   * mesh and where its parent's coarser mesh puts it, by a morph factor from the camera
   * (planet/Morph.hpp), so that a split or a merge moves heights continuously. Off by default in
   * the library (`renderer.geomorph` defaults to on). */
  bool geomorph = false;
  /** The legend of each visible layer of values (issue 24; planet/gl/src/LegendOverlay.hpp):
   * drawn into the frame after the scene (readPixels has it), bottom left or inside a dome's
   * circle, scaled by an integer factor of the frame's size. Off in the library. */
  bool legend = false;
  /** Other bodies in the scene (issue 26, `renderer.bodies`; planet/SceneBodies.hpp): each drawn
   * whole as a coarse globe with its global image (empty or unreadable: `colour`), placed and
   * turned by the ephemeris at timeUnixSeconds (none: J2000.0) in the drawn body's frame, lit by
   * the scene's sun. Only bodies with an ephemeris (earth, moon, mars) may share a scene, the drawn
   * body too (create() refuses others); an entry naming the drawn body is skipped. */
  struct SceneBody {
    Body body;
    std::filesystem::path globalImage;
    std::array<std::uint8_t, 3> colour{128, 128, 128};
  };
  std::vector<SceneBody> sceneBodies;
  bool visibleWindow = false; ///< a window the user sees (`tellus view`); else hidden
  /** With visibleWindow: frame() draws but does not show; Renderer::present() does (a cluster's
   * channel swaps only after the master's go, docs/design/cluster-live.md). */
  bool presentOnRequest = false;
  /** With visibleWindow: the swap waits for the display's refresh (swap interval 1); false: it
   * does not (the cluster master's preview, which must not hold up the frame lock). */
  bool vsync = true;
  /** A projector channel's warp and blend on the GPU (issue 28; ChannelWarp.hpp's conventions,
   * planet/gl/src/ProjectorWarp.hpp): after the scene, its image drawn through the warp mesh
   * (none: scaled) and multiplied by the blend mask (none: 1; weights of the projector's pixels)
   * into the projector's image (width x height; 0: the framebuffer's size), which the window (of
   * that size) shows and readPresented() reads. readPixels() still reads the scene. resize()
   * keeps the old size while this is set. */
  struct ProjectorCalibration {
    std::optional<WarpMesh> mesh;
    std::optional<std::vector<float>> blend;
    int width = 0;
    int height = 0;
  };
  std::optional<ProjectorCalibration> projectorWarp;
  std::string windowTitle = "tellus";
  /** Another renderer whose window and GL context this one draws in (issue 26: `view`'s B, the
   * next body in the same window), instead of opening its own; the window stays while either
   * lives. Both belong to one thread; the one whose frame() runs last shows. */
  const Renderer* shareWindowOf = nullptr;
};

/** Where one frame's time went on the main thread (wall clock, ms). GL calls only queue work;
 * `finish` is the GL executing the frame (on llvmpipe: rasterising on the CPU). */
struct FramePhases {
  double update = 0.0; ///< quadtree + streamer
  /** Received tiles kept, decodes launched, decoded textures taken and given a GL texture. */
  double intake = 0.0;
  double upload = 0.0; ///< glTexSubImage2D bands
  std::size_t uploadBytes = 0;
  double mesh = 0.0; ///< node meshes built and sent (VBOs)
  std::size_t meshesCreated = 0;
  double draw = 0.0;   ///< draw calls issued
  double finish = 0.0; ///< glFinish
  double total = 0.0;  ///< the whole frame (= frameMs)
};

/** What the renderer did: the last frame's figures and totals since creation. */
struct RenderStats {
  std::uint64_t frames = 0;
  std::size_t nodesVisible = 0; ///< last frame: passed culling
  std::size_t nodesDrawn = 0;
  std::size_t mergedNodesDrawn = 0; ///< last frame: polar nodes spanning several tiles
  std::size_t nodesCreated = 0;     ///< last frame
  std::size_t nodesCreatedTotal = 0;
  std::size_t nodesInTree = 0;
  std::int32_t maxLevel = 0;
  std::size_t tilesRequested = 0; ///< totals
  std::size_t tilesReceived = 0;
  std::size_t tilesAbsent = 0;
  std::size_t tilesFailed = 0;
  std::size_t tilesInFlight = 0; ///< now
  std::size_t texturesDecoded = 0;
  std::size_t decodeErrors = 0;
  std::size_t texturesUploaded = 0;
  std::size_t bytesReceived = 0;
  std::size_t bytesUploaded = 0;
  std::size_t decodesPending = 0; ///< now
  std::size_t uploadsPending = 0;
  std::size_t texturesResident = 0;
  std::size_t textureBytes = 0; ///< resident node textures (LRU), every layer
  std::size_t poolTextures = 0; ///< free textures kept for reuse
  std::size_t texturesReused = 0;
  std::size_t texturesEvicted = 0;
  std::size_t heightTilesRequested = 0; ///< totals
  std::size_t heightTilesReceived = 0;
  std::size_t heightTilesAbsent = 0;
  std::size_t heightTilesFailed = 0;
  std::size_t meshesBuilt = 0;       ///< total
  std::size_t meshesBuiltLast = 0;   ///< last frame
  double meshMs = 0.0;               ///< last frame: building meshes (heights, edge fixing)
  double meshMsTotal = 0.0;          ///< since creation
  std::size_t edgesFixed = 0;        ///< last frame: drawn node sides moved onto a coarser edge
  std::size_t zeroAreaTriangles = 0; ///< last frame: in the drawn meshes
  bool cameraLifted = false;         ///< last frame: the pose was below terrain + clearance
  std::size_t nodesWithoutHeights =
      0;                 ///< last frame: drawn nodes on the bare ellipsoid (sub-pixel relief)
  double updateMs = 0.0; ///< last frame: quadtree + streamer CPU time
  double longestUpdateMs = 0.0; ///< the longest update since creation
  double frameMs = 0.0;         ///< last frame: everything, GL finished
  FramePhases phases;           ///< last frame, phase by phase
  /** Per layer (the base first, then the overlays): its time, a time it is switching to, tiles and
   * textures. */
  struct Layer {
    std::string name;
    std::string time;
    std::string pendingTime; ///< "" = none: the layer swaps to it once its tiles are ready
    double opacity = 1.0;
    bool visible = true;
    int maxLevel = -1;              ///< as set (-1: the layer's own deepest)
    bool night = false;             ///< a night layer (LayerOptions::night)
    int levels = 0;                 ///< levels drawn now (its own, or up to maxLevel)
    std::size_t tilesRequested = 0; ///< totals, of every time
    std::size_t tilesReceived = 0;
    std::size_t texturesResident = 0; ///< now
    std::size_t swaps = 0;            ///< time changes completed
    /** Time that plays (issue 24; Renderer::animateLayer): nullopt when not animated. */
    struct Animation {
      std::string state;  ///< "playing", "holding" (waiting for the target's tiles), "paused",
                          ///< "ended"
      std::string target; ///< the instant asked for (shown once `time` equals it)
      std::size_t instants = 0;
      std::size_t steps = 0;          ///< instants shown after being asked for
      std::size_t heldSteps = 0;      ///< of them, shown only after frames of holding
      double heldSeconds = 0.0;       ///< the frame clock's seconds those held in all
      std::size_t aheadRequested = 0; ///< tiles of the next times fetched ahead (totals)
      std::size_t aheadReceived = 0;
      std::size_t aheadInFlight = 0;    ///< now
      std::size_t aheadMaxInFlight = 0; ///< the most at once (never above the bound)
      std::size_t aheadWanted = 0;      ///< last frame: the drawn nodes' tiles at the times ahead
      std::size_t aheadSettled = 0;     ///< ... of them answered
    };
    std::optional<Animation> animation;
  };
  std::vector<Layer> layers;
  int overlaysPerPass = 0; ///< overlay textures blended in one pass
  int passes = 0;          ///< last frame: draw passes (1 + those the overlays needed)
  std::string glVersion;   ///< GL_VERSION and GL_RENDERER
  bool reversedZ = false;  ///< glClipControl available (4.5 or ARB_clip_control)
  /** The atmosphere's tables: milliseconds their computation took when the renderer was made
   * (0: no atmosphere). */
  double atmospherePrecomputeMs = 0.0;
  /** The dome's last frame: "direct" or "cube" (a direct renderer's frame whose estimated
   * straight-edge error exceeded DomeOptions::directMaxErrorPx is "cube"); "" without a dome.
   * domeErrorPx: that estimate (0 for the cube method's renderers). */
  std::string domeMethod;
  double domeErrorPx = 0.0;
  /** GPU bytes of the dome's cube faces (6 RGBA8 faces and a float depth buffer): 0 for a
   * direct renderer until a frame first falls back to the cube. */
  std::size_t domeFaceBytes = 0;
  std::string domeError; ///< why the cube faces could not be made ("" when they could)
  /** The scene's time of the last frame (UTC, POSIX seconds; nullopt: none) and whether the globe
   * was lit by the sun (RendererOptions::sunlight or sunLatLon): what a render was drawn at. */
  std::optional<double> sceneTimeUnixSeconds;
  bool sunlight = false;
};

class Renderer {
public:
  /** Opens the GL context (4.5 core, else 3.3 core) and loads the global texture. The source and
   * the geodesy must outlive the renderer. Fails with a message (no display, no GL 3.3, unknown
   * layer). */
  static std::expected<std::unique_ptr<Renderer>, std::string>
  create(ITileSource& source, const Geodesy& geodesy, RendererOptions options);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  /** The camera a pose gives at this renderer's size and field of view (throws
   * std::invalid_argument for a pose the Camera refuses). */
  Camera camera(const CameraPose& pose) const;
  /** The pose with its altitude raised to the terrain under it (the deepest height data loaded)
   * plus the clearance, when lower (thesis 4.5.3); frame() draws every pose through this. */
  CameraPose clampToTerrain(const CameraPose& pose) const;
  /** The pose the last frame was drawn from (after clampToTerrain). */
  CameraPose drawnPose() const;
  /** Terrain height in metres (exaggerated) at a point from the deepest height data loaded
   * (bilinear); 0 without an elevation layer. */
  double terrainHeight(double latDeg, double lonDeg) const;
  /** The body the renderer draws (the one given to create()). */
  const Geodesy& geodesy() const noexcept;
  /** One frame: quadtree and streamer update, decoded textures to upload, uploads within the
   * budget, draw into the framebuffer (and the window when visible). */
  void frame(const CameraPose& pose);
  /** The last frame's state (its quadtree, draw list, textures, meshes, fades' weights and
   * heights) drawn again from another pose, changing nothing: no update, intake, upload or mesh
   * build, no frame counted, no stats. What popping is measured against (bench/popping.sh,
   * docs/design/popping.md): the next frame from the same pose differs from this image only by
   * what its streaming and LOD change. Parts of the view the last frame culled stay background.
   * No-op before the first frame. */
  void redrawLast(const CameraPose& pose);
  /** The last frame shows what its LOD asks for: every drawn node has its own texture or its
   * tiles are absent (or undecodable), no split was deferred, and nothing is in flight, decoding
   * or uploading. A frame drawn when this holds is deterministic. */
  bool complete() const noexcept;
  /** Something is being fetched, decoded or uploaded (a loop may sleep when not). */
  bool busy() const noexcept;
  /** The framebuffer as RGBA8, rows from the top. */
  std::vector<std::uint8_t> readPixels() const;
  /** What the window shows (or would): the projector's image (RendererOptions::projectorWarp),
   * else the framebuffer; RGBA8, rows from the top, width() x height(). */
  std::vector<std::uint8_t> readPresented() const;
  /** Shows the last frame in the visible window and swaps (RendererOptions::presentOnRequest;
   * frame() does it otherwise). No-op without a visible window. */
  void present();
  const RenderStats& stats() const noexcept;
  int width() const noexcept;
  int height() const noexcept;

  /** The visible window (visibleWindow): whether the user closed it, and its native handle
   * (GLFWwindow*) for the view loop's input. Null when hidden. */
  bool windowShouldClose() const noexcept;
  void* nativeWindow() const noexcept;
  /** A line drawn at the top left of the visible window over the globe (the statistics line of
   * `tellus view`); never part of readPixels(). Empty: none. */
  void setOverlayText(std::string text);
  /** Layers: 0 is the base imagery, 1.. the overlays in drawing order. Out-of-range indices and
   * values are refused with std::invalid_argument. */
  std::size_t layerCount() const noexcept;
  void setLayerOpacity(std::size_t layer, double opacity); ///< overlays only; [0, 1]
  void setLayerVisible(std::size_t layer, bool visible);   ///< overlays only
  /** Switches a layer to another time. The new time's tiles for the visible nodes are fetched
   * first (the old time's requests stop), and the layer swaps to them all at once when every
   * visible node has its texture of the new time (or none exists), never tile by tile. Setting
   * the time again before that replaces the pending time; the current time cancels it. */
  void setLayerTime(std::size_t layer, std::string time);
  /** Time that plays (issue 24; planet/TimeAnimation.hpp): the layer steps through the
   * animation's instants on the frame clock (RendererOptions::frameClock, else the steady
   * clock), each swapped in whole through setLayerTime once its tiles for the view are all there
   * (the shown time holds until then: RenderStats::Layer::animation says "holding"), and the
   * tiles of the next fetchAhead instants for the drawn nodes asked for ahead at a priority below
   * every visible tile (at most aheadInFlight at once; planet/TimePrefetch.hpp). Replaces an
   * animation of that layer; nullopt stops it. Out-of-range layers refused (invalid_argument). */
  void animateLayer(std::size_t layer, std::optional<TimeAnimation> animation);
  /** The layer's animation (nullptr: none, or no such layer). */
  const TimeAnimation* layerAnimation(std::size_t layer) const noexcept;
  /** `view`'s keys: pause or play the layer's animation from now on the frame clock, or step it
   * by hand (paused); no-ops for a layer without one. */
  void toggleLayerAnimation(std::size_t layer);
  void stepLayerAnimation(std::size_t layer, int delta);
  /** The deepest level of a layer fetched and drawn (-1: the layer's own deepest). Swapped in like
   * a time change: the textures the new limit needs first, then all at once. */
  void setLayerMaxLevel(std::size_t layer, int maxLevel);
  /** Layers of values (issue 24): the options a layer is drawn with now (nullopt for imagery or
   * an index past the layers), and new ones (the same layer's format; its colour map and range
   * changed: `view`'s keys). Refused with std::invalid_argument for an imagery layer, an unknown
   * colour map or a range that is not min < max (log: > 0). */
  std::optional<ValueLayerOptions> layerValues(std::size_t layer) const;
  void setLayerValues(std::size_t layer, const ValueLayerOptions& values);
  /** The value a layer of values holds at a point (values::sample's rule, the shader's, on the
   * deepest resident texture there): NaN for no data or nothing resident; nullopt for an imagery
   * layer. */
  std::optional<float> layerValueAt(std::size_t layer, double latDeg, double lonDeg) const;
  /** Shows or hides the legends (RendererOptions::legend) from the next frame on. */
  void setLegend(bool on);
  bool legend() const noexcept;
  /** Moves an overlay to another place in the drawing order (both indices 1..). */
  void moveLayer(std::size_t from, std::size_t to);
  /** Resizes the framebuffer (window resize). */
  void resize(int width, int height);
  /** The scene's time from the next frame on (UTC, POSIX seconds; nullopt: none), as
   * RendererOptions::timeUnixSeconds: the sun and the sky follow it. */
  void setTime(std::optional<double> unixSeconds);
  /** The scene's time the last frame was drawn at (nullopt: none). */
  std::optional<double> time() const noexcept;

private:
  struct Impl;
  explicit Renderer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/** An elevation tile's bytes (BIL16, or an 8/16-bit greyscale PNG) as metres: what the renderer's
 * height streaming does on its workers, for tools (`tellus height`). Thread safe. */
std::expected<HeightTile, std::string> decodeHeightTile(const TileKey& key,
                                                        int width,
                                                        int height,
                                                        std::span<const std::byte> bytes,
                                                        std::string_view contentType,
                                                        const HeightEncoding& encoding);

/** Writes RGBA8 (rows from the top) as an 8-bit RGB PNG (alpha dropped). False with a message. */
bool writePngRgb(const std::filesystem::path& file,
                 int width,
                 int height,
                 const std::vector<std::uint8_t>& rgba,
                 std::string* error);

/** Reads a JPEG or PNG file as RGBA8 (rows from the top). For tests and tools. */
std::expected<RgbaImage, std::string> readImageFile(const std::filesystem::path& file);
/** Encodes RGBA8 as a PNG in memory (for test tile sources). */
std::vector<std::byte> encodePngRgba(int width, int height, const std::vector<std::uint8_t>& rgba);

} // namespace tellus::planet
