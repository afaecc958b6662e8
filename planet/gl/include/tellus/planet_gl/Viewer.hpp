#pragma once
/**
 * @file Viewer.hpp
 * @brief `tellus view`: the interactive loop around a Renderer made with visibleWindow. GLFW stays
 * private to tellus::planet_gl.
 *
 * Controls: left-drag moves the camera over the ground (the point under the cursor follows it,
 * roughly), a double-click flies to the point under the cursor (three times closer, 1.5 s, eased;
 * a drag or R interrupts), the wheel zooms with a speed proportional to the altitude, W/S tilt,
 * A/D turn the heading, R resets to the start pose, P writes a screenshot PNG, Esc or closing the
 * window quits. Layers (issue #7): a digit selects a layer (0 the base, 1-9 the overlays; an
 * overlay's digit also shows or hides it), - and = lower and raise the selected overlay's opacity
 * by 0.1, , and . move it down and up the drawing order, ; and ' lower and raise the deepest
 * level drawn of the selected layer, [ and ] step the selected layer's time through its configured
 * values (the layer swaps when the new time's tiles are all there). The scene's time (issue 23;
 * the sun, the night side, the sky) runs with the wall clock from ViewerOptions::sceneTime: L runs
 * it faster and H slower (x1, x10, x60, x600, x3600, x86400 its pace, real time the slowest), J
 * turns it backwards (or forwards again), K pauses and resumes it, N goes back to now at real
 * time (SceneClock, planet/SceneTime.hpp). Layers of values (issue 24; planet/gl/src/
 * ViewerValues.hpp): C cycles the colour map of the selected value layer (else the first one),
 * Z and X narrow and widen its range, Q and E shift it down and up, G shows or hides the
 * legends; the value under the cursor ("title value unit") ends the statistics line. Time that
 * plays (issue 24; planet/gl/src/ViewerAnimation.hpp): Space plays or pauses an animated layer
 * (Renderer::animateLayer; the selected one, else the first), [ and ] step an animated selected
 * layer's animation by hand, and each animated layer's "name TIME state" joins the statistics
 * line (holding: the next time's tiles are not all there yet). B orbits the next of the scene's
 * bodies (ViewerOptions::bodies, issue 26). The
 * statistics line (fps, nodes drawn, tiles in flight,
 * texture MB, camera, the scene's time and its pace) is drawn at the top left of the window (its
 * own 5 x 7 font, TextOverlay.cpp) and is the window title, refreshed twice a second.
 */

#include <tellus/cache/Clock.hpp>
#include <tellus/planet_gl/Renderer.hpp>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace tellus::planet {

struct ViewerOptions {
  CameraPose start;
  std::filesystem::path screenshotDir = "."; ///< tellus-<n>.png
  /** Stop after this many frames (0: until closed); for tests. */
  std::uint64_t maxFrames = 0;
  /** Per layer (0 the base, then the overlays): the times [ and ] step through; empty: none. */
  std::vector<std::vector<std::string>> layerTimes;
  /** The scene's time at the start (UTC, POSIX seconds; `tellus view` gives --time or now);
   * nullopt: the renderer's own, and the time keys do nothing. */
  std::optional<double> sceneTime;
  /** The clock the scene's time runs with (steady() paces it, now() is N's "now"); null: the
   * system's. Tests pass a ManualClock. */
  std::shared_ptr<const Clock> clock;
  /** Issue 26: the bodies B steps through, the orbited one first (`tellus view`: it and the
   * scene's others); B with two or more ends the loop with `end` saying the next one, the pose and
   * the scene's time, and the caller makes the renderer of that body (keeping the eye where it
   * is, FlightBodies.hpp poseOverOtherBody). */
  std::vector<std::string> bodies;
  struct End {
    std::string nextBody; ///< "": the window was closed (or maxFrames reached)
    CameraPose pose;
    std::optional<double> sceneTime;
  };
  End* end = nullptr;
};

/** Runs until the window closes (or maxFrames). Returns the number of frames drawn. */
std::uint64_t runViewer(Renderer& renderer, const ViewerOptions& options);

} // namespace tellus::planet
