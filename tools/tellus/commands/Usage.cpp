// `tellus --help`: every command and its options (tests/cli/test_options.sh reads it).

#include "Commands.hpp"

namespace tellus::commands {

// clang-format off
const char* const kUsage = R"(usage: tellus <command> [options]

commands:
  seed     fill the cache from the layers' upstreams
             [--layer NAME]... [--levels A-B] [--bbox W,S,E,N] [--dry-run]
             [--time T] [--concurrency N] [--rate TILES/S] [--retries N] [--refresh]
             --time T: one TIME, a list T1,T2 or a range A/B/P (A/B: the layer's times
                                      within); each checked against the layer's grid
                                      before anything is fetched, at most 1000
             [--meta-tiles N]         N x N tiles per WMS GetMap (default: the upstream's
                                      meta_tiles, 4; 1 = one GetMap per tile)
  cache    inspect and maintain the cache
             stats [--json] | verify | rebuild
             | prune --older-than DURATION [--layer NAME] [--include-pinned] [--dry-run]
                                      DURATION: e.g. 30d, 12h, 15m, 45s; says what it removes
                                      (every layer unless --layer) before it does
             | export --gpkg FILE --layer NAME [--levels A-B] | import --gpkg FILE --layer NAME
  serve    the WMS / WMTS / World Wind tile server
             [--listen HOST:PORT] [--threads N] [--offline]
             [--log-level error|warn|info|debug] [--access-log FILE|-]
  render   headless globe rendering to PNG (an X display or xvfb-run)
             --camera LAT,LON,ALT[,HEADING,TILT] --out FILE.png [--size WxH]
             [--wait-complete[=SECONDS]] [--background R,G,B] [--stats FILE.json]
             [--layer NAME] [--threshold T] [--earth wgs84|sphere] [--offline | --server URL]
             [--dome [FOV]] [--dome-tilt DEG]  a domemaster (angular fisheye, FOV 180 up to
                                      220 degrees, --size N: N x N, black outside the circle)
             [--dome-method direct|cube]  one pass through the fisheye (default) or cube
                                      faces and a warp (renderer.dome.method)
             [--channel CONFIG.json|FILE.mpcdi[,NAME]]  one cluster channel's frustum and
                                      size (tellus cluster; its warp and blend not applied)
             or a flight: --path PATH.json --frames DIR [--fps N] [--repeat N] instead of
             --camera/--out; [--probe-frames DIR] (as streamed) before each frame the last
                                      frame's state drawn from its pose (bench/popping.sh)
             (PATH.json: [{"time":0,"lat":..,"lon":..,"alt":..,"heading":..,"tilt":..,
              "times":{"LAYER":"TIME"},"utc":"2024-06-20T18:00:00Z"}, ...]: a layer's time
              from that keyframe on; "utc" the scene's time, interpolated between keyframes)
  cluster  the dome as projector channels over MPI (docs/design/cluster.md):
             mpirun -n K tellus cluster CONFIG.json --out DIR (K = channels + 1)
             (or --mpcdi FILE.mpcdi for CONFIG.json: a VESA MPCDI calibration,
              profiles "2d" and "3d", one channel a region)
             --camera LAT,LON,ALT[,HEADING,TILT] | --path PATH.json [--fps N] (render's
             keyframes: "times", "utc", "body": each rank a renderer per body)
             [--wait-complete[=SECONDS]] [--background R,G,B] [--dome-tilt DEG] and
             render's globe options;
             rank 0 sends each frame's state, rank i draws channel i:
             DIR/channel-NAME-FRAME.png, DIR/digest-NAME.txt (digest-master.txt);
             live: [--loop] (until SIGINT/SIGTERM) [--realtime] (paced at --fps)
             [--channel-timeout S] (10: a channel silent that long is lost, the others
             go on; mpirun --enable-recovery) [--port FILE] (rejoining channels: both
             jobs under mpirun --ompi-server file:URI); a channel restarted alone:
             mpirun -n 1 tellus cluster CONFIG.json --join NAME --port FILE (as the master);
             [--control 127.0.0.1:PORT] the console: GET /status, POST /camera, /time,
             /path, /layer (HTTP/JSON on loopback; PORT 0: any, printed)
             [--render-scale S] each channel rendered at S x its projector's size (0.25-4;
             CONFIG.json's "render" [W, H] per channel), warped down to the projector's;
             [--window] each channel in a window of its size, warped and blended on the
             GPU, swapped after the master's go (PNGs as without it);
             [--preview [SIZE]] the master's window: the dome as a domemaster (render
             --dome --size SIZE; 512), DIR/preview.png its last frame (both need a display)
  view     the interactive globe (a GLFW window)
             [--camera LAT,LON,ALT[,HEADING,TILT]] [--size WxH] [--layer NAME] [--threshold T]
             [--earth wgs84|sphere] [--offline | --server URL] [--dome [FOV]] [--dome-tilt DEG] [--dome-method direct|cube]; drag, wheel, W/S tilt, A/D heading, R reset, P screenshot, Esc
             render and view: [--time ISO8601|now] the scene's time, UTC (renderer.time;
                                      default: render 2024-03-20T12:00:00Z, view now)
             [--no-sun] unlit imagery (renderer.sunlight) [--no-night] no night layers
                                      (renderer.night; renderer.layers[].night: true)
             [--no-stars] (renderer.stars: the star background from data/stars-hip-6.5.txt)
             [--no-atmosphere] (renderer.atmosphere.enabled: the sky and the air's haze)
             [--atmosphere-resolution full|half|quarter] (renderer.atmosphere.resolution:
                                      the sky and haze computed at that fraction; full)
             [--no-fade-in] [--no-geomorph] (renderer.fade_in, renderer.geomorph: no popping)
             [--no-terrain] [--exaggeration X] [--sun LAT,LON]
             [--min-relief-px PX] (renderer.terrain.min_relief_px: heights only where relief shows)
             [--overlay NAME[,OPACITY]]... (imagery or value layers over the base, a value
             layer coloured by its colour map; also renderer.layers)
             [--legend | --no-legend] the value layers' legends (renderer.legend; default:
             view on, render off);
             [--animate LAYER=TIMES]... time that plays (TIMES as seed --time; render: with
             --path) [--rate N] times a second (1) [--once] (default: loop) [--fetch-ahead K]
                                      the next K times' tiles fetched ahead (2)
             view: 0-9 select a layer (1-9 also show/hide it), - = opacity, , . order,
             ; ' deepest level, [ ] its time; the scene's time: L faster, H slower,
             J backwards, K pause, N now; --animate: Space plays/pauses, [ ] step it;
             value layers (the selected, else the first): C next colour map, Z X
             narrow/widen its range, Q E shift it, G legends; the value under the cursor
             and each animated layer's TIME and state end the status line
             render: [--edge-fixing on|off] (off shows the cracks it closes; for comparisons)
             render, view and height: [--geoid on|off] (renderer.geoid: mean-sea-level heights
             onto the ellipsoid, h = H + N; the Earth's only)
             render, view and height: [--body NAME] (renderer.body: earth, moon, mars or a
             configured one; only its layers are used; none for it: a bare fallback globe)
             render and view: [--bodies LIST] (renderer.bodies: the other bodies in the scene,
             of earth, moon, mars; each placed by the ephemeris at the scene's time; view: B
             orbits the next of them in the same window, the eye kept; render --path:
             keyframes' "body": the camera orbits the body it is near, unless --body pins it)
             render, for the speed/accuracy sweep (bench/trade.sh): [--mesh-size N]
             [--upload-per-frame BYTES] [--vertices double|float]
  height   the terrain height in metres at a point, from the elevation layer's deepest level
             --lat A --lon B [--elevation LAYER] [--datum msl|ellipsoid] [--offline | --server URL]
             (prints H above mean sea level, or h = H + N with --datum ellipsoid; both on stderr)
             or --values LAYER: the value of a layer of values there (or "no data"; its unit
             on stderr), as GetFeatureInfo answers it

options for every command (anything else is refused with exit code 2; --help prints this):
  --cache DIR   cache root (default: $TELLUS_CACHE, $XDG_CACHE_HOME/tellus or ~/.cache/tellus)
  --data DIR    bundled data of the embedded default (default: $TELLUS_DATA_DIR or the source tree)
  --config F    a YAML configuration (docs/CONFIG.md; default: the embedded default)
)";
// clang-format on

} // namespace tellus::commands
