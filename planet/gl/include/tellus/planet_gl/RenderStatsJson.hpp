#pragma once
/**
 * @file RenderStatsJson.hpp
 * @brief The statistics of a render (`tellus render --stats FILE.json`): the renderer's figures
 * (RenderStats), whether the image or every frame of a flight was complete, and each frame's time
 * with its median, 95th and 99th percentile and where the longest frame's time went.
 *
 * The document is one JSON object, a member per line (bench/flight_stats.py, the bench scripts and
 * tests/cli read it):
 *
 *     {
 *       "complete": true,
 *       "seconds": 1.234,
 *       ...
 *       "layers": [
 *         {"name": "bluemarble", "time": "", ...}
 *       ],
 *       "median_frame_ms": 5.000,
 *       ...
 *       "frame_times_ms": [5.000, 4.000],
 *       ...
 *     }
 *
 * "scene_time" is the scene's time of the last frame (issue 23) as ISO 8601 UTC
 * ("2024-03-20T12:00:00Z", whole seconds; "scene_time_unix" the POSIX seconds with three decimals),
 * null for none; "sunlight" whether the globe was lit; each layer says whether it is "night".
 * "body" is the body orbited at the last frame and "orbit_switches" each change of it along a
 * flight between bodies (issue 26), [{"frame": 61, "body": "moon"}].
 * Times are milliseconds with three decimals (seconds for "seconds"), "dome_error_px" four
 * significant digits or null when infinite (an edge the direct method cannot map), counts are
 * integers. Strings are JSON strings (escaped; invalid UTF-8 replaced by U+FFFD).
 */

#include <tellus/planet_gl/Renderer.hpp>

#include <cstddef>
#include <span>
#include <string>

namespace tellus::planet {

/** The frame times of a run (FramePhases::total, ms): median (the upper one of an even count),
 * 95th and 99th percentile by nearest rank, the longest and which frame it was (the first of
 * equals) with its phases. All 0 for no frames. */
struct FrameTimeSummary {
  double medianMs = 0.0;
  double p95Ms = 0.0;
  double p99Ms = 0.0;
  double longestMs = 0.0;
  std::size_t longestIndex = 0;
  FramePhases longest; ///< all 0 when no frame took any time
};

FrameTimeSummary summarizeFrameTimes(std::span<const FramePhases> frames);

/** A flight between bodies changed the body orbited (issue 26): from frame `frame` on, `body`. */
struct OrbitSwitch {
  std::size_t frame = 0;
  std::string body;
};

/** What a render did, as `--stats` writes it. */
struct RenderRun {
  double seconds = 0.0;  ///< wall clock from the first frame to the end
  bool complete = false; ///< the image (every frame of a flight) showed what its LOD asked for
  std::span<const FramePhases> frames; ///< every frame drawn, in order
  std::span<const double> frameCpuMs;  ///< the process's CPU time of each frame (all threads)
  /** The body orbited at the last frame ("": neither it nor the switches are written) and each
   * change of it along a flight. */
  std::string body;
  std::span<const OrbitSwitch> orbitSwitches;
};

/** The statistics document (see the file comment), ending in a newline. */
std::string renderStatsJson(const RenderStats& stats, const RenderRun& run);

} // namespace tellus::planet
